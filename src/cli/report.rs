//! What the command prints after a render: timings and statistics.

use std::path::Path;
use std::sync::Mutex;
use std::time::Duration;

use crate::bvh::Bvh;
use crate::integrator::lights::{LightSet, LightSource};
use crate::scene::Scene;
use crate::wavefront::{RenderOutput, Stats};

/// The closing lines of a render. `adaptive_max`: `-s` when sampling was
/// adaptive, so that the line can say how many pixels stopped before it.
pub fn timings(
    output: &Path,
    load: Duration,
    build: Duration,
    render: Duration,
    result: &RenderOutput,
    threads: usize,
    adaptive_max: Option<u32>,
) {
    let rays = result.stats.rays() as f64;
    eprintln!(
        "wrote {} ({}x{}, {})",
        output.display(),
        result.image.width,
        result.image.height,
        samples_taken(&result.image.samples, adaptive_max, result.complete)
    );
    eprintln!(
        "load {:.3} s | BVH build {:.3} s | render {:.3} s on {} | {:.2} Mrays/s",
        load.as_secs_f64(),
        build.as_secs_f64(),
        render.as_secs_f64(),
        count(threads, THREADS),
        rays / render.as_secs_f64().max(1e-9) / 1e6
    );
}

/// `n` and `what`, `what` given as singular and plural: "1 light", "2 lights".
fn count(n: usize, (one, many): (&str, &str)) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

const THREADS: (&str, &str) = ("thread", "threads");

/// The emitters the renderer samples, by kind, and the lights of colour 0
/// it leaves out: what the shadow-ray and probe counts follow from.
fn emitters(lights: &LightSet) -> String {
    let mut kinds: Vec<((&str, &str), usize)> = Vec::new();
    for light in &lights.sources {
        let (kind, n) = match light {
            LightSource::Point { .. } => (("point light", "point lights"), 1),
            LightSource::Directional { .. } => (("directional light", "directional lights"), 1),
            LightSource::Rectangle { .. } => (("area light", "area lights"), 1),
            LightSource::Hemisphere { .. } => (("hemisphere light", "hemisphere lights"), 1),
            LightSource::Environment(_) => (("environment map", "environment maps"), 1),
            LightSource::Sphere { .. } => (("emissive sphere", "emissive spheres"), 1),
            LightSource::Mesh { triangles, .. } => {
                (("emissive triangle", "emissive triangles"), triangles.len())
            }
        };
        match kinds.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, total)) => *total += n,
            None => kinds.push((kind, n)),
        }
    }
    if lights.dark > 0 {
        kinds.push((("light of colour 0", "lights of colour 0"), lights.dark));
    }
    if kinds.is_empty() {
        return "none".into();
    }
    let parts: Vec<String> = kinds.iter().map(|&(kind, n)| count(n, kind)).collect();
    parts.join(", ")
}

/// `shading_bytes`: the renderer's per-triangle shading records.
pub fn stats(
    (scene, lights): (&Scene, &LightSet),
    (bvh, shading_bytes): (&Bvh, usize),
    stats: &Stats,
    render: Duration,
    threads: usize,
) {
    let g = &scene.geometry;
    eprintln!(
        "scene: {}, {}, {}; emitters: {}",
        count(g.triangles.len(), ("triangle", "triangles")),
        count(g.spheres.len(), ("sphere", "spheres")),
        count(scene.materials.len(), ("material", "materials")),
        emitters(lights)
    );
    let tree = match bvh.node_count() {
        // --accel none, or nothing to build a tree over.
        0 => "no tree: every ray tests every primitive".to_string(),
        nodes => format!(
            "{}, depth {}",
            count(nodes, ("wide node", "wide nodes")),
            bvh.depth()
        ),
    };
    eprintln!(
        "bvh: {} ({tree}; {:.1} KiB, {:.1} bytes/primitive)",
        bvh.accel(),
        bvh.memory_bytes() as f64 / 1024.0,
        bvh.memory_bytes() as f64 / bvh.primitive_count().max(1) as f64
    );
    eprintln!(
        "shading records: {:.1} KiB ({:.0} bytes/triangle)",
        shading_bytes as f64 / 1024.0,
        shading_bytes as f64 / g.triangles.len().max(1) as f64
    );
    let t = &stats.traversal;
    let per_ray = |x: u64| x as f64 / t.rays.max(1) as f64;
    eprintln!(
        "traversal: {} rays, {:.1} nodes visited/ray, {:.1} primitives tested/ray",
        t.rays,
        per_ray(t.nodes_visited),
        per_ray(t.primitives_tested)
    );
    let total: u64 = stats.stages().iter().map(|(_, _, s)| s.nanos).sum();
    eprintln!(
        "{:<12} {:>14}  {:<31} {:>7} {:>8}",
        "stage", "items", "of", "time %", "calls"
    );
    for (name, what, s) in stats.stages() {
        if s.runs == 0 {
            eprintln!(
                "{name:<12} {:>14}  {what:<31} {:>7} {:>8}",
                "skipped", "-", 0
            );
            continue;
        }
        eprintln!(
            "{name:<12} {:>14}  {what:<31} {:>6.1}% {:>8}",
            s.items,
            100.0 * s.nanos as f64 / total.max(1) as f64,
            s.runs
        );
    }
    eprintln!(
        "calls: waves of paths through the stage (generate once more per tile pass, \
         to find the pass done; film once per tile pass)"
    );
    let secs = render.as_secs_f64().max(1e-9);
    eprintln!(
        "throughput: {:.2} Mrays/s, {:.2} Msamples/s ({}; stage times are summed over threads)",
        stats.rays() as f64 / secs / 1e6,
        stats.samples as f64 / secs / 1e6,
        count(threads, THREADS)
    );
}

/// The samples per pixel on average and, when sampling was adaptive (up
/// to `adaptive_max`), how many pixels stopped early: "64.0" alone would
/// hide a few pixels that stopped at 32. After an interrupt (not
/// `complete`) the average, and the range where counts differ, are over
/// the pixels rendered (those of any sample), and pixels cut short cannot
/// be told from pixels that converged, so no early count is given.
fn samples_taken(samples: &[u32], adaptive_max: Option<u32>, complete: bool) -> String {
    let rendered = samples.iter().filter(|&&n| n > 0).count();
    let total: u64 = samples.iter().map(|&n| n as u64).sum();
    if !complete {
        let mean = total as f64 / rendered.max(1) as f64;
        // Tiles take their passes in turn, so the rendered pixels' counts
        // are a pass apart at most: the range says how even the image is.
        let taken = samples.iter().copied().filter(|&n| n > 0);
        let range = match (taken.clone().min(), taken.max()) {
            (Some(least), Some(most)) if least < most => format!(" ({least} to {most})"),
            _ => String::new(),
        };
        return format!(
            "interrupted: {rendered} of {} pixels rendered, {mean:.2} samples/pixel on average{range}",
            samples.len()
        );
    }
    let mean = total as f64 / samples.len().max(1) as f64;
    match adaptive_max {
        None => format!("{mean:.1} samples/pixel on average"),
        Some(max) => {
            let early = samples.iter().filter(|&&n| n < max).count();
            format!(
                "{mean:.2} samples/pixel on average; {early} of {} pixels stopped before {max}",
                samples.len()
            )
        }
    }
}

/// Progress for a log: where stderr is not a terminal there is no bar, so
/// a long render prints a line now and then — at most once per `every`,
/// the first after `every` — saying how far it is and how long it may
/// take. Renders shorter than `every` print none. Work is counted in the
/// renderer's progress units (pixel samples of the budget, see
/// [`Renderer::render`](crate::wavefront::Renderer::render)).
pub struct ProgressLines {
    total: u64,
    every: Duration,
    /// Units done, and when the last line was due.
    state: Mutex<(u64, Duration)>,
}

impl ProgressLines {
    pub fn new(total_units: u64, every: Duration) -> Self {
        ProgressLines {
            total: total_units.max(1),
            every,
            state: Mutex::new((0, Duration::ZERO)),
        }
    }

    /// Counts `units` more done, `elapsed` into the render; returns the
    /// line to print, if one is due. None once all is done: the closing
    /// report follows.
    pub fn advance(&self, units: u64, elapsed: Duration) -> Option<String> {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        state.0 += units;
        let done = state.0;
        if done >= self.total || elapsed < state.1 + self.every {
            return None;
        }
        state.1 = elapsed;
        let fraction = done as f64 / self.total as f64;
        let secs = elapsed.as_secs_f64();
        let left = if done == 0 {
            "time left unknown".to_string()
        } else {
            format!("about {:.0} s left", secs * (1.0 - fraction) / fraction)
        };
        // Rounded down: "100%" only once all is done (and then no line).
        Some(format!(
            "progress: {}% done, {secs:.0} s elapsed, {left}",
            (100.0 * fraction).floor()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::{LightSet, LightSource, ProgressLines, emitters, samples_taken};
    use crate::integrator::lights::TrianglePick;
    use glam::Vec3;
    use std::time::Duration;

    /// Emitters of one kind are added up, in the order first met; the
    /// emissive triangles count one by one; lights of colour 0 come last.
    #[test]
    fn emitters_are_counted_by_kind() {
        let point = LightSource::Point {
            position: Vec3::Y,
            intensity: Vec3::ONE,
        };
        let mesh = |n: usize| LightSource::Mesh {
            triangles: vec![[Vec3::X, Vec3::Y, Vec3::Z]; n],
            radiance: vec![Vec3::ONE; n],
            pick: TrianglePick::by_area(&vec![1.0; n]),
            scene_extent: 1.0,
        };
        let sphere = LightSource::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
            radiance: Vec3::ONE,
        };
        let set = |sources: Vec<LightSource>, dark: usize| LightSet {
            sources,
            dark,
            ..LightSet::default()
        };
        assert_eq!(
            emitters(&set(vec![point.clone(), mesh(3), point, sphere], 2)),
            "2 point lights, 3 emissive triangles, 1 emissive sphere, 2 lights of colour 0"
        );
        assert_eq!(emitters(&set(vec![mesh(1)], 0)), "1 emissive triangle");
        assert_eq!(emitters(&set(vec![], 1)), "1 light of colour 0");
        assert_eq!(emitters(&set(vec![], 0)), "none");
    }

    #[test]
    fn progress_lines_come_at_most_once_per_interval() {
        let s = Duration::from_secs;
        let lines = ProgressLines::new(1000, s(10));
        // Nothing in the first interval, however far the render gets.
        assert_eq!(lines.advance(100, s(5)), None);
        assert_eq!(
            lines.advance(150, s(10)).as_deref(),
            Some("progress: 25% done, 10 s elapsed, about 30 s left")
        );
        assert_eq!(lines.advance(100, s(19)), None);
        assert_eq!(
            lines.advance(150, s(20)).as_deref(),
            Some("progress: 50% done, 20 s elapsed, about 20 s left")
        );
        // 99.9% is not called 100%; all done, the closing report says the rest.
        assert_eq!(
            lines.advance(499, s(30)).as_deref(),
            Some("progress: 99% done, 30 s elapsed, about 0 s left")
        );
        assert_eq!(lines.advance(1, s(40)), None);
        // Before any pixel is done, no time left is guessed.
        let stuck = ProgressLines::new(1000, s(10));
        assert_eq!(
            stuck.advance(0, s(12)).as_deref(),
            Some("progress: 0% done, 12 s elapsed, time left unknown")
        );
    }

    #[test]
    fn the_sample_count_says_how_many_pixels_stopped_early() {
        // Three pixels at the maximum and one that stopped at half: the
        // mean alone (56.00) would round to the maximum at one decimal
        // for a large image.
        let samples = [64, 64, 32, 64];
        assert_eq!(
            samples_taken(&samples, Some(64), true),
            "56.00 samples/pixel on average; 1 of 4 pixels stopped before 64"
        );
        assert_eq!(
            samples_taken(&[64; 4], Some(64), true).split("; ").nth(1),
            Some("0 of 4 pixels stopped before 64")
        );
        assert_eq!(
            samples_taken(&samples, None, true),
            "56.0 samples/pixel on average"
        );
        // An interrupted render: pixels of no sample were not rendered;
        // those cut short are not counted as stopping early.
        let cut = [64, 0, 32, 64, 0];
        for adaptive in [Some(64), None] {
            assert_eq!(
                samples_taken(&cut, adaptive, false),
                "interrupted: 3 of 5 pixels rendered, 53.33 samples/pixel on average (32 to 64)"
            );
        }
        // Every pixel at the same count: no range.
        assert_eq!(
            samples_taken(&[16, 16], None, false),
            "interrupted: 2 of 2 pixels rendered, 16.00 samples/pixel on average"
        );
    }
}
