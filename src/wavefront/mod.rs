//! The wavefront renderer: ray batches moving through separate stages.
//!
//! The image is cut into tiles, sampled in passes; each pass of a tile
//! gives every pixel still in its adaptive mask the same number of new
//! samples, run as waves of paths:
//!
//! generate → intersect → shade → shadow-test → compact (→ refill)
//!
//! The threads take tile passes progressively (every tile's first pass,
//! then every tile's second, …; module `schedule`), so a render stopped
//! early has sampled the whole image evenly.
//!
//! Every path's result lands in its own slot; at the end of a pass the
//! slots are summed into the film in sample order. The image is therefore
//! a pure function of the seed: thread count, batch size and scheduling
//! cannot change a bit of it.

pub mod compact;
pub mod generate;
pub mod paths;
mod schedule;
pub mod shade;
pub mod shadow;
pub mod stats;
pub mod surface;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use glam::Vec3;

use crate::bvh::Bvh;
use crate::film::adaptive::{Adaptive, converged};
use crate::film::{Image, Tile, TileFilm};
use crate::integrator::bsdf::{self, Surface};
use crate::integrator::lights::LightSet;
use crate::integrator::{Settings, View};
use crate::ray::Hits;
use crate::scene::Scene;

use generate::{CameraRays, PassQueue};
use paths::{Paths, ShadowRays};
use schedule::TileQueue;
pub use stats::{Stage, Stats};

/// Most samples per pixel in one pass, whatever `-a` asks. Small, so that
/// every tile's first pass (the whole image at 16 samples) comes early
/// and a stopped render has every pixel within 16 samples of every other;
/// large enough that a 16 × 16 tile's pass is a full wave of 4096 paths.
/// It bounds the slot buffer (a pass's radiance, kept until it is summed
/// in sample order) to 16 × 12 bytes per pixel of the tile. A convergence
/// test every `samples_per_batch` above that spans several passes; as the
/// film sums each pixel's samples one by one in sample order, the split
/// changes no bit. (Measured faster than passes of 8, 32 or 64: PERF.md.)
const MAX_PASS: u32 = 16;

/// What to render and how.
#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Camera samples per pixel (the maximum when adaptive).
    pub spp: u32,
    /// With one sample per pixel, trace each pixel's centre (the CS184
    /// renderer's rule, so that a 1-spp render matches its pixel for
    /// pixel) rather than a random point of the pixel. An estimate of the
    /// pixel's average (`converge`'s renders, whose reference averages
    /// over each pixel) turns this off.
    pub centre_single_sample: bool,
    pub adaptive: Option<Adaptive>,
    pub seed: u32,
    /// Paths per wave.
    pub batch_size: usize,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// Thin-lens aperture radius (0 = pinhole) and focal distance.
    pub lens_radius: f32,
    pub focal_distance: f32,
    pub integrator: Settings,
    /// Render only these pixels of the `width × height` image (`-p`); the
    /// output is then an image of the region's size.
    pub region: Option<Tile>,
}

impl RenderSettings {
    /// The pixels rendered: the region (which must lie inside the image,
    /// as the command line checks), or the whole image.
    pub fn area(&self) -> Tile {
        let area = self.region.unwrap_or(Tile::whole(self.width, self.height));
        debug_assert!(
            u64::from(area.x0) + u64::from(area.width) <= u64::from(self.width)
                && u64::from(area.y0) + u64::from(area.height) <= u64::from(self.height),
            "region {area:?} outside the {}x{} image",
            self.width,
            self.height
        );
        area
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 800,
            height: 600,
            spp: 1,
            centre_single_sample: true,
            adaptive: None,
            seed: 0,
            batch_size: 4096,
            tile_size: 16,
            lens_radius: 0.0,
            focal_distance: 4.7,
            integrator: Settings::default(),
            region: None,
        }
    }
}

/// The scene prepared for rendering: everything the stages read.
pub struct Renderer<'a> {
    pub scene: &'a Scene,
    pub bvh: &'a Bvh,
    pub surfaces: Vec<Surface>,
    pub lights: LightSet,
    /// The triangles as the shading stage reads them (see [`surface`]).
    pub triangles: surface::TriangleRecords,
    /// Problems worth telling the user once (fallback materials, no lights).
    pub warnings: Vec<String>,
}

/// Buffers reused from pass to pass: one per thread, so passes allocate
/// almost nothing once the first few have grown them.
#[derive(Default)]
struct Scratch {
    paths: Paths,
    hits: Hits,
    shading: shade::ShadeScratch,
    shadow: ShadowRays,
    probes: ShadowRays,
    probe_hits: Hits,
    occluded: Vec<bool>,
    cost: Vec<u32>,
    slots: Vec<Vec3>,
}

/// A finished (or interrupted) render.
pub struct RenderOutput {
    pub image: Image,
    pub stats: Stats,
    /// False when cancelled before every tile was done.
    pub complete: bool,
}

impl<'a> Renderer<'a> {
    pub fn new(scene: &'a Scene, bvh: &'a Bvh) -> Self {
        let mut warnings = Vec::new();
        let surfaces = bsdf::prepare(&scene.materials, &mut warnings);
        let lights = LightSet::new(scene, &surfaces);
        Renderer {
            scene,
            bvh,
            surfaces,
            lights,
            triangles: surface::TriangleRecords::new(&scene.geometry.triangles),
            warnings,
        }
    }

    /// Renders on the current rayon pool; `cancel` stops the render between
    /// passes. `on_progress` is called after each pass of a tile with the
    /// work done, in units of [`progress_total`](Self::progress_total): a
    /// pixel's samples, and when a pixel converges, the samples of `-s` it
    /// will not take.
    ///
    /// Tiles take their passes progressively (module `schedule`), in groups
    /// of at most [`PROGRESSIVE_PIXELS`] pixels; a tile keeps its sums from
    /// its first pass to its last ([`pass_state_bytes`] for a group).
    pub fn render(
        &self,
        settings: &RenderSettings,
        on_progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> RenderOutput {
        self.render_in_groups(settings, on_progress, cancel, PROGRESSIVE_PIXELS)
    }

    /// [`render`](Self::render) with groups of at most `group_pixels`.
    fn render_in_groups(
        &self,
        settings: &RenderSettings,
        on_progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
        group_pixels: usize,
    ) -> RenderOutput {
        // A region (`-p`) is rendered in place: each of its pixels draws the
        // random numbers it draws in a whole render, so it gets the same
        // value; the image holds the region only.
        let area = settings.area();
        let workers = rayon::current_num_threads();
        let tiles = area.split_for(settings.tile_size, workers);
        // Tiles are stored into the image as soon as they finish, so a tile
        // of a single pass (a render of up to 16 samples) holds its sums
        // only while it renders, as each thread's next tile reuses the
        // memory; tiles of several passes hold theirs until their last.
        let image = Mutex::new(Image::new(area.width, area.height));
        let stats = Mutex::new(Stats::default());
        let store = |state: TileState| {
            lock(&image).store(&state.film, area);
            // Counted from the film, so that an interrupted render counts
            // the passes it finished.
            lock(&stats).samples += state.film.count.iter().map(|&n| n as u64).sum::<u64>();
        };
        let mut complete = true;
        // No samples, nothing to render: a black image, complete.
        let groups = match settings.spp {
            0 => Vec::new(),
            _ => tile_groups(&tiles, group_pixels),
        };
        for group in groups {
            if cancel.load(Ordering::Relaxed) {
                complete = false;
                break;
            }
            let slots: Vec<Mutex<TileSlot>> = group
                .iter()
                .map(|_| Mutex::new(TileSlot::Waiting))
                .collect();
            let queue = TileQueue::new(0..group.len());
            // One worker per thread, each with its own buffers for the
            // whole group; the locks are taken once per tile pass.
            rayon::scope(|scope| {
                for _ in 0..workers {
                    scope.spawn(|_| {
                        let mut scratch = Scratch::default();
                        let mut own = Stats::default();
                        while !cancel.load(Ordering::Relaxed)
                            && let Some((pass, t)) = queue.take()
                        {
                            let mut slot = lock(&slots[t]);
                            let state = slot.start(group[t]);
                            own += self.render_pass(settings, state, on_progress, &mut scratch);
                            let more = !state.finished(settings.spp);
                            if !more {
                                store(slot.finish());
                            }
                            drop(slot);
                            if more {
                                queue.give_back(t, pass + 1);
                            }
                        }
                        *lock(&stats) += own;
                    });
                }
            });
            // Tiles cut short by a stop keep the passes they finished.
            for slot in slots {
                match slot.into_inner().unwrap_or_else(PoisonError::into_inner) {
                    TileSlot::Stored => {}
                    TileSlot::Rendering(state) => {
                        store(state);
                        complete = false;
                    }
                    TileSlot::Waiting => complete = false,
                }
            }
            if !complete {
                break;
            }
        }
        let mut image = image.into_inner().unwrap_or_else(PoisonError::into_inner);
        let stats = stats.into_inner().unwrap_or_else(PoisonError::into_inner);
        if settings.integrator.view == View::BvhCost {
            // The film holds the mean traversal steps per pixel: map to a
            // heat scale (whose top is the image's, or the region's, most).
            let max = image
                .pixels
                .iter()
                .map(|p| p.x)
                .fold(0.0f32, f32::max)
                .max(1.0);
            for p in &mut image.pixels {
                p.x /= max;
                *p = crate::film::output::rate_colour(p.x);
            }
        }
        RenderOutput {
            image,
            stats,
            complete,
        }
    }

    /// The units of work a render reports to its `on_progress`: every
    /// pixel's `-s` samples.
    pub fn progress_total(settings: &RenderSettings) -> u64 {
        settings.area().pixel_count() as u64 * u64::from(settings.spp)
    }

    /// Renders the next pass of one tile: for each pixel still in its
    /// mask, the samples up to its next convergence test, at most
    /// [`MAX_PASS`] and at most what is left of `-s`; then the test, where
    /// one is due.
    fn render_pass(
        &self,
        settings: &RenderSettings,
        state: &mut TileState,
        on_progress: &(dyn Fn(u64) + Sync),
        scratch: &mut Scratch,
    ) -> Stats {
        let mut stats = Stats::default();
        let TileState {
            film,
            active,
            taken,
        } = state;
        let tile = film.tile;
        let view = self.scene.camera.view(settings.width, settings.height);
        let cam = CameraRays {
            camera: &self.scene.camera,
            view,
            seed: settings.seed,
            pixel_centre: settings.spp == 1 && settings.centre_single_sample,
            lens_radius: settings.lens_radius,
            focal_distance: settings.focal_distance,
        };
        let integrator = &settings.integrator;
        let inputs = shade::ShadeInputs {
            geometry: &self.scene.geometry,
            triangles: &self.triangles,
            surfaces: &self.surfaces,
            lights: &self.lights,
            settings: integrator,
        };
        let capacity = settings.batch_size.max(1);
        let Scratch {
            paths,
            hits,
            shading,
            shadow,
            probes,
            probe_hits,
            occluded,
            cost,
            slots,
        } = scratch;
        paths.truncate(0);
        cost.resize(capacity, 0);
        let test_every = samples_between_tests(settings);
        let want_cost = integrator.view == View::BvhCost;
        let n_pass = (test_every - *taken % test_every)
            .min(MAX_PASS)
            .min(settings.spp - *taken);
        slots.clear();
        slots.resize(active.len() * n_pass as usize, Vec3::ZERO);
        let mut queue = PassQueue {
            tile,
            active,
            samples_per_pixel: n_pass,
            first_sample: *taken,
            next: 0,
        };
        loop {
            let t = Instant::now();
            let generated = generate::refill(paths, capacity, &mut queue, &cam);
            stats.generate.record(generated, t);
            if paths.is_empty() {
                break;
            }

            let t = Instant::now();
            let cost_out = want_cost.then(|| &mut cost[..paths.len()]);
            self.bvh
                .intersect(&paths.rays, hits, &mut stats.traversal, cost_out);
            stats.intersect.record(paths.len(), t);
            if want_cost {
                for (r, &c) in paths.radiance.iter_mut().zip(cost.iter()) {
                    *r = Vec3::splat(c as f32);
                }
            }

            let t = Instant::now();
            shadow.clear();
            probes.clear();
            shade::shade(&inputs, hits, paths, shading, shadow, probes);
            stats.shade.record(paths.len(), t);

            if !shadow.is_empty() {
                let t = Instant::now();
                shadow::resolve_shadow_rays(
                    self.bvh,
                    shadow,
                    occluded,
                    paths,
                    &mut stats.traversal,
                );
                stats.shadow.record(shadow.len(), t);
            }
            if !probes.is_empty() {
                let t = Instant::now();
                shadow::resolve_probe_rays(
                    self.bvh,
                    probes,
                    probe_hits,
                    &self.scene.geometry,
                    &self.surfaces,
                    &self.lights,
                    paths,
                    &mut stats.traversal,
                );
                stats.probe.record(probes.len(), t);
            }

            let t = Instant::now();
            let before = paths.len();
            compact::compact(paths, slots);
            stats.compact.record(before, t);
        }

        // Sum the pass into the film in sample order, then update the mask.
        let t = Instant::now();
        for (&pixel, samples) in active.iter().zip(slots.chunks_exact(n_pass as usize)) {
            film.add(pixel as usize, samples);
        }
        *taken += n_pass;
        let mut progress = active.len() as u64 * u64::from(n_pass);
        if let Some(adaptive) = settings.adaptive
            && *taken % test_every == 0
        {
            let before = active.len();
            active.retain(|&p| {
                let p = p as usize;
                !converged(
                    film.count[p],
                    film.illum_sum[p],
                    film.illum_sq_sum[p],
                    adaptive.tolerance,
                )
            });
            // The samples the converged pixels will not take count as done.
            progress += (before - active.len()) as u64 * u64::from(settings.spp - *taken);
        }
        stats.film.record(slots.len(), t);
        on_progress(progress);
        stats
    }
}

/// Samples between convergence tests; without adaptive sampling (no test
/// is run) [`MAX_PASS`], so that passes are as long as they may be.
fn samples_between_tests(settings: &RenderSettings) -> u32 {
    settings
        .adaptive
        .map_or(MAX_PASS, |a| a.samples_per_batch)
        .max(1)
}

/// The pixels of the tiles whose sums a render keeps at once: 2^21, so an
/// image of up to 1920 × 1080 takes all its passes progressively as one
/// group; a larger one is rendered group by group (runs of consecutive
/// tiles, row-major), each progressively.
pub const PROGRESSIVE_PIXELS: usize = 1 << 21;

/// What a tile keeps between its passes, per pixel: its film's sums and
/// count, and its place in the adaptive mask.
pub const PASS_STATE_BYTES_PER_PIXEL: u64 =
    TileFilm::BYTES_PER_PIXEL + std::mem::size_of::<u32>() as u64;

/// The bytes a render of `pixels` pixels keeps between passes, besides
/// its image: the pass state of one group.
pub fn pass_state_bytes(pixels: u64) -> u64 {
    pixels.min(PROGRESSIVE_PIXELS as u64) * PASS_STATE_BYTES_PER_PIXEL
}

/// `tiles` cut into runs of consecutive tiles of at most `budget` pixels
/// (a tile larger than that is a run alone).
fn tile_groups(tiles: &[Tile], budget: usize) -> Vec<&[Tile]> {
    let mut groups = Vec::new();
    let (mut start, mut pixels) = (0, 0);
    for (i, tile) in tiles.iter().enumerate() {
        if pixels > 0 && pixels + tile.pixel_count() > budget {
            groups.push(&tiles[start..i]);
            (start, pixels) = (i, 0);
        }
        pixels += tile.pixel_count();
    }
    if start < tiles.len() {
        groups.push(&tiles[start..]);
    }
    groups
}

/// Locks `m`; a lock poisoned by a panic elsewhere still gives its data
/// (the panic reaches the caller on its own).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// One tile between its passes.
struct TileState {
    film: TileFilm,
    /// The tile's pixels still sampled (local indices): the adaptive mask.
    active: Vec<u32>,
    /// Samples taken by every pixel still in the mask.
    taken: u32,
}

impl TileState {
    fn new(tile: Tile) -> TileState {
        TileState {
            film: TileFilm::new(tile),
            active: (0..tile.pixel_count() as u32).collect(),
            taken: 0,
        }
    }

    /// No pass left: every sample taken, or every pixel converged.
    fn finished(&self, spp: u32) -> bool {
        self.taken >= spp || self.active.is_empty()
    }
}

/// Where a tile of a group is: not started, between passes, or done and
/// stored into the image (its sums freed).
enum TileSlot {
    Waiting,
    Rendering(TileState),
    Stored,
}

impl TileSlot {
    /// The tile's state, made at its first pass.
    fn start(&mut self, tile: Tile) -> &mut TileState {
        if let TileSlot::Waiting = self {
            *self = TileSlot::Rendering(TileState::new(tile));
        }
        match self {
            TileSlot::Rendering(state) => state,
            TileSlot::Waiting | TileSlot::Stored => unreachable!("a stored tile is not queued"),
        }
    }

    /// Takes the finished tile's state to be stored.
    fn finish(&mut self) -> TileState {
        match std::mem::replace(self, TileSlot::Stored) {
            TileSlot::Rendering(state) => state,
            TileSlot::Waiting | TileSlot::Stored => unreachable!("only a started tile finishes"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::Accel;

    /// Groups are runs of whole tiles in order, each within the budget
    /// (an image of up to 1920 × 1080: one group), and together they are
    /// every tile once.
    #[test]
    fn tile_groups_cover_the_tiles_within_the_budget() {
        let pixels = |g: &[Tile]| g.iter().map(Tile::pixel_count).sum::<usize>();
        let budget = PROGRESSIVE_PIXELS;
        let hd = Tile::whole(1920, 1080).split(16);
        assert_eq!(tile_groups(&hd, budget), [&hd[..]]);
        for (w, h) in [(4000, 4000), (2049, 1024), (16, 16)] {
            let tiles = Tile::whole(w, h).split(16);
            let groups = tile_groups(&tiles, budget);
            assert_eq!(groups.concat(), tiles, "{w}x{h}");
            assert!(groups.iter().all(|g| pixels(g) <= budget));
            // Each group but the last is full: one more tile would not fit.
            for pair in groups.windows(2) {
                assert!(pixels(pair[0]) + pair[1][0].pixel_count() > budget);
            }
        }
        // A tile larger than the budget is a group of its own.
        let huge = [Tile::whole(2048, 2048), Tile::whole(1, 1)];
        assert_eq!(tile_groups(&huge, budget).len(), 2);
        assert!(tile_groups(&[], budget).is_empty());
    }

    /// Rendered group by group, an image has every pixel in its place
    /// (the same bits as in one group); stopped in the first group, the
    /// render says it is incomplete and never starts the next.
    #[test]
    fn groups_render_into_place_and_a_stop_ends_the_render() {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae"));
        let scene = crate::scene::collada::load_file(path).unwrap();
        let bvh = Bvh::build(&scene.geometry, Accel::Sah);
        let renderer = Renderer::new(&scene, &bvh);
        let settings = RenderSettings {
            width: 40,
            height: 24,
            spp: 32,
            tile_size: 8,
            ..RenderSettings::default()
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let run = |group_pixels: usize, stop_after: usize| {
            let cancel = AtomicBool::new(false);
            let passes = std::sync::atomic::AtomicUsize::new(0);
            let on_progress = |_| {
                if passes.fetch_add(1, Ordering::Relaxed) + 1 >= stop_after {
                    cancel.store(true, Ordering::Relaxed);
                }
            };
            let out = pool.install(|| {
                renderer.render_in_groups(&settings, &on_progress, &cancel, group_pixels)
            });
            (out, passes.into_inner())
        };
        // 15 tiles of 8 × 8, two passes each; groups of five tiles (a row
        // of the image).
        let (one, _) = run(PROGRESSIVE_PIXELS, usize::MAX);
        let (rows, passes) = run(320, usize::MAX);
        assert!(one.complete && rows.complete);
        assert_eq!(passes, 30);
        assert_eq!(one.image.samples, rows.image.samples);
        assert!(one.image.samples.iter().all(|&n| n == 32));
        for (a, b) in one.image.pixels.iter().zip(&rows.image.pixels) {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
        assert_eq!(one.stats.samples, 40 * 24 * 32);
        assert_eq!(rows.stats.samples, 40 * 24 * 32);
        // Stopped after two passes: some tiles of the first row have had
        // their first pass (and the pass in flight on the other thread
        // finishes), the other rows nothing.
        let (stopped, passes) = run(320, 2);
        assert!(!stopped.complete);
        assert!((2..=3).contains(&passes), "{passes}");
        let rendered = |rows: std::ops::Range<usize>| {
            stopped.image.samples[rows.start * 40..rows.end * 40]
                .iter()
                .filter(|&&n| n > 0)
                .count()
        };
        assert_eq!(rendered(0..8), passes * 64);
        assert_eq!(rendered(8..24), 0);
        assert_eq!(stopped.stats.samples, passes as u64 * 64 * 16);
        // Nothing to render (no samples): complete, black.
        let none = pool.install(|| {
            renderer.render(
                &RenderSettings { spp: 0, ..settings },
                &|_| {},
                &AtomicBool::new(false),
            )
        });
        assert!(none.complete && none.image.samples.iter().all(|&n| n == 0));
    }
}
