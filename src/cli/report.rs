//! What the command prints after a render: timings and statistics.

use std::path::Path;
use std::time::Duration;

use crate::bvh::Bvh;
use crate::scene::Scene;
use crate::wavefront::{RenderOutput, Stats};

pub fn timings(
    output: &Path,
    load: Duration,
    build: Duration,
    render: Duration,
    result: &RenderOutput,
    threads: usize,
) {
    let rays = result.stats.rays() as f64;
    eprintln!(
        "wrote {} ({}x{}, {:.1} samples/pixel on average)",
        output.display(),
        result.image.width,
        result.image.height,
        result.stats.samples as f64 / (result.image.width as f64 * result.image.height as f64)
    );
    eprintln!(
        "load {:.3} s | BVH build {:.3} s | render {:.3} s on {threads} thread{} | {:.2} Mrays/s",
        load.as_secs_f64(),
        build.as_secs_f64(),
        render.as_secs_f64(),
        if threads == 1 { "" } else { "s" },
        rays / render.as_secs_f64().max(1e-9) / 1e6
    );
}

/// `shading_bytes`: the renderer's per-triangle shading records.
pub fn stats(
    scene: &Scene,
    (bvh, shading_bytes): (&Bvh, usize),
    stats: &Stats,
    render: Duration,
    threads: usize,
) {
    let g = &scene.geometry;
    eprintln!(
        "scene: {} triangles, {} spheres, {} lights, {} materials",
        g.triangles.len(),
        g.spheres.len(),
        scene.lights.len(),
        scene.materials.len()
    );
    eprintln!(
        "bvh: {} ({} wide nodes, depth {}, {:.1} KiB, {:.1} bytes/primitive)",
        bvh.accel(),
        bvh.node_count(),
        bvh.depth(),
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
    let total: u64 = stats.stages().iter().map(|(_, s)| s.nanos).sum();
    eprintln!(
        "{:<12} {:>14} {:>8} {:>10}",
        "stage", "items", "time %", "runs"
    );
    for (name, s) in stats.stages() {
        if s.runs == 0 {
            eprintln!("{name:<12} {:>14} {:>8} {:>10}", "skipped", "-", 0);
            continue;
        }
        eprintln!(
            "{name:<12} {:>14} {:>7.1}% {:>10}",
            s.items,
            100.0 * s.nanos as f64 / total.max(1) as f64,
            s.runs
        );
    }
    let secs = render.as_secs_f64().max(1e-9);
    eprintln!(
        "throughput: {:.2} Mrays/s, {:.2} Msamples/s ({} threads; stage times are summed over threads)",
        stats.rays() as f64 / secs / 1e6,
        stats.samples as f64 / secs / 1e6,
        threads
    );
}
