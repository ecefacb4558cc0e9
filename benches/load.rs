//! Scene load time (parse + flatten + smooth normals) for the CS184 scenes.
//!
//! Run: `cargo bench --bench load`. Reads `../shared/scenes/cs184/`; prints a
//! note and measures nothing when that folder is absent.

use std::path::PathBuf;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use wavepath::scene::collada::load_file;

const SCENES: &[&str] = &[
    "sky/CBspheres_lambertian.dae",
    "sky/CBbunny.dae",
    "sky/bunny.dae",
    "meshedit/cow.dae",
    "meshedit/beetle.dae",
    "meshedit/maxplanck.dae",
    "keenan/banana.dae",
    "keenan/building.dae",
    "basic/plane16384.dae",
];

fn load(c: &mut Criterion) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/cs184");
    if !dir.is_dir() {
        eprintln!("skipping: {} is absent", dir.display());
        return;
    }
    let mut group = c.benchmark_group("load");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300));
    for rel in SCENES {
        let path = dir.join(rel);
        group.bench_function(*rel, |b| b.iter(|| load_file(&path).unwrap()));
    }
    group.finish();
}

criterion_group!(benches, load);
criterion_main!(benches);
