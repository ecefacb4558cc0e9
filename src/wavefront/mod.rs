//! The wavefront renderer: ray batches moving through separate stages.
//!
//! The image is cut into tiles, one rayon task each. A task samples its
//! tile in passes; each pass gives every pixel still in the adaptive mask
//! the same number of new samples, run as waves of paths:
//!
//! generate → intersect → shade → shadow-test → compact (→ refill)
//!
//! Every path's result lands in its own slot; at the end of a pass the
//! slots are summed into the film in sample order. The image is therefore
//! a pure function of the seed: thread count, batch size and scheduling
//! cannot change a bit of it.

pub mod compact;
pub mod generate;
pub mod paths;
pub mod shade;
pub mod shadow;
pub mod stats;
pub mod surface;

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

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
pub use stats::{Stage, Stats};

/// Most samples per pixel in one pass, whatever `-a` asks: bounds the
/// slot buffer (a pass's radiance, kept until it is summed in sample
/// order) to 64 × 12 bytes per pixel of the tile. A convergence test
/// every `samples_per_batch` above that spans several passes; as the film
/// sums each pixel's samples one by one in sample order, the split
/// changes no bit.
const MAX_PASS: u32 = 64;

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

/// Buffers reused from tile to tile: rayon's `for_each_init` makes one per
/// split of the tile list (a handful per thread, not one per tile), so
/// tiles allocate almost nothing once the first few have grown them.
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
    pub fn render(
        &self,
        settings: &RenderSettings,
        on_progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> RenderOutput {
        // A region (`-p`) is rendered in place: each of its pixels draws the
        // random numbers it draws in a whole render, so it gets the same
        // value; the image holds the region only.
        let area = settings.area();
        let tiles = area.split_for(settings.tile_size, rayon::current_num_threads());
        // Each tile is stored into the image as soon as it is done, so only
        // the tiles in flight hold their f64 sums: kept for the whole image
        // until the end, they took 68 bytes per pixel more than the image's
        // 28. One lock per tile (not per ray); a store writes only its own
        // pixels and the counters add up exactly, so the order in which
        // tiles finish changes nothing.
        let totals = Mutex::new((Image::new(area.width, area.height), Stats::default(), true));
        tiles
            .par_iter()
            .for_each_init(Scratch::default, |scratch, &tile| {
                let (film, s, done) =
                    self.render_tile(settings, tile, cancel, on_progress, scratch);
                {
                    let mut totals = totals.lock().unwrap_or_else(|e| e.into_inner());
                    totals.0.store(&film, area);
                    totals.1 += s;
                    totals.2 &= done;
                }
            });
        let (mut image, stats, complete) = totals.into_inner().unwrap_or_else(|e| e.into_inner());
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

    fn render_tile(
        &self,
        settings: &RenderSettings,
        tile: Tile,
        cancel: &AtomicBool,
        on_progress: &(dyn Fn(u64) + Sync),
        scratch: &mut Scratch,
    ) -> (TileFilm, Stats, bool) {
        let mut film = TileFilm::new(tile);
        let mut stats = Stats::default();
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
        let mut active: Vec<u32> = (0..tile.pixel_count() as u32).collect();
        // Samples between convergence tests.
        let test_every = settings
            .adaptive
            .map_or(MAX_PASS, |a| a.samples_per_batch)
            .max(1);
        let mut taken = 0;
        let want_cost = integrator.view == View::BvhCost;

        let mut done = true;
        while taken < settings.spp && !active.is_empty() {
            if cancel.load(Ordering::Relaxed) {
                done = false;
                break;
            }
            let n_pass = (test_every - taken % test_every)
                .min(MAX_PASS)
                .min(settings.spp - taken);
            slots.clear();
            slots.resize(active.len() * n_pass as usize, Vec3::ZERO);
            let mut queue = PassQueue {
                tile,
                active: &active,
                samples_per_pixel: n_pass,
                first_sample: taken,
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
                        self.lights.sky,
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
            taken += n_pass;
            let mut progress = active.len() as u64 * u64::from(n_pass);
            if let Some(adaptive) = settings.adaptive
                && taken % test_every == 0
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
                progress += (before - active.len()) as u64 * u64::from(settings.spp - taken);
            }
            stats.film.record(slots.len(), t);
            on_progress(progress);
        }
        // Counted from the film, so that a tile cut short by Ctrl-C counts
        // the passes it finished.
        stats.samples += film.count.iter().map(|&n| n as u64).sum::<u64>();
        (film, stats, done)
    }
}
