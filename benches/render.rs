//! Whole-renderer throughput: samples/s for the CS184 scenes at 480×360,
//! `-m 5 -l 4` (fixed sampling so every run does the same work), and the
//! batch-size sweep that chose the default `--batch-size`.
//!
//! Run: `cargo bench --bench render`. Needs `../shared/scenes/cs184/`
//! (prints a note and measures nothing without it). Mrays/s for each run
//! is printed by `wavepath --stats` on the same settings.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use wavepath::bvh::{Accel, Bvh};
use wavepath::integrator::Settings;
use wavepath::scene::Scene;
use wavepath::scene::collada::load_file;
use wavepath::wavefront::{RenderSettings, Renderer};

fn scene(rel: &str) -> Option<Scene> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/scenes/cs184")
        .join(rel);
    if !path.is_file() {
        eprintln!("skipping: {} is absent", path.display());
        return None;
    }
    Some(load_file(&path).unwrap())
}

fn settings(spp: u32, batch_size: usize) -> RenderSettings {
    RenderSettings {
        width: 480,
        height: 360,
        spp,
        batch_size,
        integrator: Settings {
            max_depth: 5,
            light_samples: 4,
            ..Settings::default()
        },
        ..RenderSettings::default()
    }
}

fn render(renderer: &Renderer, s: &RenderSettings) {
    let cancel = AtomicBool::new(false);
    let out = renderer.render(s, &|_| {}, &cancel);
    assert!(out.complete);
}

fn scenes(c: &mut Criterion) {
    let mut group = c.benchmark_group("render_480x360_m5_l4");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .warm_up_time(Duration::from_millis(500));
    let spp = 4;
    group.throughput(Throughput::Elements(480 * 360 * spp as u64));
    for rel in ["sky/CBspheres_lambertian.dae", "sky/CBbunny.dae"] {
        let Some(scene) = scene(rel) else { continue };
        let bvh = Bvh::build(&scene.geometry, Accel::Sah);
        let renderer = Renderer::new(&scene, &bvh);
        let s = settings(spp, RenderSettings::default().batch_size);
        group.bench_function(rel, |b| b.iter(|| render(&renderer, &s)));
    }
    group.finish();
}

fn batch_sizes(c: &mut Criterion) {
    let Some(scene) = scene("sky/CBbunny.dae") else {
        return;
    };
    let bvh = Bvh::build(&scene.geometry, Accel::Sah);
    let renderer = Renderer::new(&scene, &bvh);
    let mut group = c.benchmark_group("batch_size_CBbunny");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(6))
        .warm_up_time(Duration::from_millis(500));
    // 32 samples per pass over a 16×16 tile: 8192 paths per pass, so every
    // batch size below is exercised.
    let spp = 32;
    group.throughput(Throughput::Elements(240 * 180 * spp as u64));
    for batch in [256usize, 512, 1024, 2048, 4096, 8192] {
        let s = RenderSettings {
            width: 240,
            height: 180,
            adaptive: None,
            ..settings(spp, batch)
        };
        group.bench_with_input(BenchmarkId::from_parameter(batch), &s, |b, s| {
            b.iter(|| render(&renderer, s))
        });
    }
    group.finish();
}

criterion_group!(benches, scenes, batch_sizes);
criterion_main!(benches);
