//! BVH benchmarks: build time and trace throughput, optionally side by side
//! with Embree 3 on the very same rays.
//!
//! ```text
//! cargo bench --bench bvh                          # wavepath only
//! cargo bench --bench bvh --features embree        # + Embree (apt-get install libembree-dev)
//! BVH_BENCH_SCENES=CBbunny,maxplanck cargo bench --bench bvh --features embree
//! BVH_BENCH_SCALING=1 cargo bench --bench bvh -- scaling   # 1k..4M triangle sweep
//! BVH_BENCH_QUICK=1 cargo bench --bench bvh --features embree  # plain table, see below
//! BVH_BENCH_PROFILE=primary cargo bench --bench bvh   # one set, traced once, for a profiler
//! BVH_BENCH_PROFILE=diffuse BVH_BENCH_ENGINE=embree-1 cargo bench --bench bvh --features embree
//!                                        # the same with one of Embree's modes instead
//! BVH_BENCH_PROFILE=threads cargo bench --bench bvh --features embree  # 1→all-thread scaling
//!                                        # (and the machine's own, from two FMA kernels)
//! BVH_BENCH_PROFILE=batches cargo bench --bench bvh   # per-batch times: is the VM preempting?
//! BVH_BENCH_EMBREE_CONFIG=verbose=2 …   # Embree prints its BVH statistics (SAH cost, nodes)
//! BVH_BENCH_EMBREE_ROBUST=1 …   # Embree's robust mode (RTC_SCENE_FLAG_ROBUST), for a
//!                                        # reading at robustness closer to wavepath's own
//! ```
//!
//! `BVH_BENCH_QUICK=1` skips criterion and prints one table row per scene
//! and ray set: build times and Mrays/s for wavepath and Embree's
//! rtcIntersect1/rtcOccluded1 and 8- and 16-wide packet calls, on one thread
//! (measured in thread CPU time, which a busy shared machine distorts less
//! than wall time) and on all threads (wall time). `BVH_BENCH_SCENES`
//! selects scenes by name there too (`sphere1k` … `sphere4M` for the sweep).
//!
//! Scenes: CBbunny, maxplanck and building from `../shared/scenes/cs184`
//! (skipped with a message when absent) and procedural bumpy spheres of ~1M
//! and ~4M triangles. Per scene, three ray sets of up to 1024×768 rays:
//!
//! * `primary`: one ray per pixel centre from the scene camera;
//! * `diffuse`: cosine-distributed bounces from the primary hits;
//! * `shadow`: from the primary hits to random points on the first area
//!   light (or a point above the scene), any-hit queries.
//!
//! Secondary rays start off the surface by γ₈ of the hit point's
//! magnitude plus its distance to the hit triangle's farthest vertex and
//! to the camera (`ray::offset_from_surface`). With the `embree` feature,
//! each set of a triangle-only scene is first traced once by both engines
//! and their answers compared (at most one ray in 10,000 may differ; the
//! count is printed), so the rates are for the same work.
//!
//! Each set is traced in batches of 4096 rays (`BVH_BENCH_BATCH=N` to
//! change), one batch per rayon task, on a 1-thread pool and on the
//! default (all cores) pool. Throughput is
//! reported by criterion in elements (rays) per second.

use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use rayon::prelude::*;
use wavepath::bvh::{Accel, Bvh, TraversalStats};
use wavepath::ray::{Hits, NO_HIT, Rays, offset_from_surface, surface_reach};
use wavepath::scene::{Camera, Geometry, Light, Perspective, Spheres, Triangles};

const WIDTH: u32 = 1024;
const HEIGHT: u32 = 768;
/// Rays per batch (one rayon task each): `BVH_BENCH_BATCH`, default 4096.
fn batch_size() -> usize {
    std::env::var("BVH_BENCH_BATCH")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n| n > 0)
        .unwrap_or(4096)
}

/// A scene prepared for tracing.
struct Workload {
    name: String,
    geometry: Geometry,
    camera: Camera,
    light: Option<(Vec3, Vec3, Vec3)>,
}

/// Ray batches of one kind.
struct RaySet {
    kind: &'static str,
    batches: Vec<Rays>,
    shadow: bool,
}

impl RaySet {
    fn len(&self) -> usize {
        self.batches.iter().map(Rays::len).sum()
    }

    /// Result buffers for [`trace`]: closest hits and any-hit flags, one
    /// per batch.
    fn buffers(&self) -> (Vec<Hits>, Vec<Vec<bool>>) {
        let hits = self.batches.iter().map(|_| Hits::default()).collect();
        let occluded = self.batches.iter().map(|_| Vec::new()).collect();
        (hits, occluded)
    }
}

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/cs184")
}

fn wanted(name: &str) -> bool {
    match std::env::var("BVH_BENCH_SCENES") {
        Ok(list) => list.split(',').any(|s| s.trim().eq_ignore_ascii_case(name)),
        Err(_) => true,
    }
}

fn load(name: &str, rel: &str) -> Option<Workload> {
    let path = scenes_dir().join(rel);
    if !path.is_file() {
        println!("skipping {name}: {} not found", path.display());
        return None;
    }
    let scene = wavepath::scene::collada::load_file(&path).expect("scene loads");
    let light = scene.lights.iter().find_map(|l| match l {
        Light::Area {
            center,
            dim_x,
            dim_y,
            ..
        } => Some((*center, *dim_x, *dim_y)),
        _ => None,
    });
    Some(Workload {
        name: name.to_string(),
        geometry: scene.geometry,
        camera: scene.camera,
        light,
    })
}

/// Name of the [`bumpy_sphere`] of parameter `n` (4·n² triangles), known
/// before building it.
fn sphere_name(n: usize) -> String {
    let n_tris = 4 * n * n;
    if n_tris >= 1 << 20 {
        format!("sphere{}M", n_tris >> 20)
    } else {
        format!("sphere{}k", n_tris >> 10)
    }
}

/// A sphere of `4·n²` triangles with a bumpy radius (so the BVH has real
/// depth complexity), as a lat-long grid.
fn bumpy_sphere(n: usize) -> Workload {
    let (rows, cols) = (n, 2 * n);
    let mut positions = Vec::with_capacity((rows + 1) * cols);
    for i in 0..=rows {
        let theta = std::f32::consts::PI * i as f32 / rows as f32;
        for j in 0..cols {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / cols as f32;
            let r =
                1.0 + 0.05 * (13.0 * theta).sin() * (17.0 * phi).cos() + 0.02 * (57.0 * phi).sin();
            positions.push(
                r * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ),
            );
        }
    }
    let mut indices = Vec::with_capacity(2 * rows * cols);
    let idx = |i: usize, j: usize| (i * cols + j % cols) as u32;
    for i in 0..rows {
        for j in 0..cols {
            indices.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            indices.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    let n_tris = indices.len();
    let geometry = Geometry {
        triangles: Triangles {
            positions,
            normals: Vec::new(),
            indices,
            material: vec![0; n_tris],
            texcoords: Vec::new(),
        },
        spheres: Spheres::default(),
    };
    let b = geometry.bounds();
    let camera = Camera::place(
        Vec3::new(0.4, 0.5, 1.0),
        &Perspective::default(),
        b.min,
        b.max,
    );
    Workload {
        name: sphere_name(n),
        geometry,
        camera,
        light: None,
    }
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        // SplitMix64.
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn batches(rays: impl Iterator<Item = (Vec3, Vec3, f32)>) -> Vec<Rays> {
    let batch = batch_size();
    let mut out = vec![Rays::with_capacity(batch)];
    for (o, d, t) in rays {
        if out.last().unwrap().len() == batch {
            out.push(Rays::with_capacity(batch));
        }
        out.last_mut().unwrap().push(o, d, t);
    }
    out
}

/// Primary, diffuse and shadow rays for a workload.
fn ray_sets(w: &Workload, bvh: &Bvh) -> Vec<RaySet> {
    let cam = &w.camera;
    let view = cam.view(WIDTH, HEIGHT);
    let primary = batches((0..HEIGHT).flat_map(|y| {
        (0..WIDTH).map(move |x| {
            (
                cam.position,
                cam.direction(&view, x as f32 + 0.5, y as f32 + 0.5),
                f32::INFINITY,
            )
        })
    }));

    // Primary hit points with their geometric normals facing the camera,
    // moved off the surface by an error bound that grows with the distance
    // to the hit triangle's farthest vertex (the triangle test's rounding)
    // and to the camera (the rounding of o + t·d). (With a bound from p's
    // own coordinates only, 1.5% of CBbunny's diffuse rays started within
    // the floor's error and hit it again at t = 0.)
    let mut surface = Vec::new();
    for rays in &primary {
        let mut hits = Hits::default();
        bvh.intersect(rays, &mut hits, &mut TraversalStats::default(), None);
        for i in 0..rays.len() {
            if hits.prim[i] == NO_HIT {
                continue;
            }
            let d = rays.direction(i);
            let p = rays.origin(i) + hits.t[i] * d;
            let prim = hits.prim[i] as usize;
            let tris = &w.geometry.triangles;
            let (mut n, reach) = if prim < tris.len() {
                let reach = surface_reach(p, &tris.vertices(prim));
                (tris.geometric_normal(prim).normalize_or(Vec3::Y), reach)
            } else {
                let s = prim - tris.len();
                let spheres = &w.geometry.spheres;
                let n = (p - spheres.center[s]).normalize_or(Vec3::Y);
                (n, 2.0 * spheres.radius[s])
            };
            if n.dot(d) > 0.0 {
                n = -n;
            }
            // p = o + t·d also carries the rounding of t·d, which grows
            // with the distance from the camera: counted with the reach.
            let travelled = (hits.t[i] * d).abs().max_element();
            surface.push((offset_from_surface(p, n, reach + travelled), n));
        }
    }

    let mut rng = Rng(7);
    let diffuse = batches(surface.iter().map(|&(o, n)| {
        let (r1, r2) = (rng.next(), rng.next());
        let (t, b) = n.any_orthonormal_pair();
        let phi = 2.0 * std::f32::consts::PI * r2;
        let s = r1.sqrt();
        let d = s * phi.cos() * t + s * phi.sin() * b + (1.0 - r1).sqrt() * n;
        (o, d, f32::INFINITY)
    }));

    let bounds = w.geometry.bounds();
    let mut rng = Rng(11);
    let shadow = batches(surface.iter().map(|&(o, _)| {
        let target = match w.light {
            Some((c, dx, dy)) => c + (rng.next() - 0.5) * dx + (rng.next() - 0.5) * dy,
            None => bounds.center() + Vec3::Y * bounds.diagonal().length(),
        };
        // Stop just short of the light so its own geometry does not occlude.
        (o, target - o, 1.0 - 1e-4)
    }));

    vec![
        RaySet {
            kind: "primary",
            batches: primary,
            shadow: false,
        },
        RaySet {
            kind: "diffuse",
            batches: diffuse,
            shadow: false,
        },
        RaySet {
            kind: "shadow",
            batches: shadow,
            shadow: true,
        },
    ]
}

/// Traces every batch of `set` with `bvh`, in parallel on the current pool,
/// one batch per task. `with_max_len(1)` matters: by default rayon splits
/// the list into runs of about a quarter of it, and a run once started
/// cannot be stolen, so with ~30 batches of unequal cost one thread sat
/// idle for up to a third of a maxplanck shadow trace.
fn trace(bvh: &Bvh, set: &RaySet, hits: &mut [Hits], occ: &mut [Vec<bool>]) {
    // The batches are zipped with both buffers: a short one would silently
    // trace fewer batches.
    assert!(hits.len() == set.batches.len() && occ.len() == set.batches.len());
    set.batches
        .par_iter()
        .with_max_len(1)
        .zip(hits.par_iter_mut().zip(occ.par_iter_mut()))
        .for_each(|(rays, (h, o))| trace_batch(bvh, set, rays, (h, o), &mut Default::default()));
}

/// Traces one batch of `set`: closest hits into `hits`, or any hits into
/// `occluded` for a shadow set; traversal counters into `stats`.
#[inline(always)]
fn trace_batch(
    bvh: &Bvh,
    set: &RaySet,
    rays: &Rays,
    (hits, occluded): (&mut Hits, &mut Vec<bool>),
    stats: &mut TraversalStats,
) {
    if set.shadow {
        bvh.occluded(rays, occluded, stats);
    } else {
        bvh.intersect(rays, hits, stats, None);
    }
}

/// Traces every batch of `set` with Embree in `mode`, in parallel on the
/// current pool, one batch per task as in [`trace`] (camera rays flagged
/// coherent, the others incoherent).
#[cfg(feature = "embree")]
fn trace_embree(scene: &embree::Scene, set: &RaySet, mode: embree::Mode, hits: &mut [Hits]) {
    let coherent = set.kind == "primary";
    set.batches
        .par_iter()
        .with_max_len(1)
        .zip(hits.par_iter_mut())
        .for_each(|(rays, h)| scene.trace(rays, set.shadow, coherent, mode, h));
}

/// Before timing: both engines answer the same queries on `set`, in every
/// Embree mode. Hit or miss (occluded or not) must agree, and a hit must be
/// on the same primitive or, where a ray meets a shared edge and the two
/// pick different sides, at the same `t` (within 1e-4 relative, 1e-6
/// absolute). A ray through an edge may still differ, as Embree's
/// triangle test is not watertight; at most one ray in 10,000 may
/// disagree, and the count is printed. (Before the secondary rays'
/// offsets counted the distance from the camera, up to 0.16% of a set
/// did: rays starting inside a surface's error band, which wavepath,
/// whose interval [0, t_max] is closed, hit again at t = 0.)
#[cfg(feature = "embree")]
fn check_agreement(bvh: &Bvh, escene: &embree::Scene, set: &RaySet, geometry: &Geometry) {
    if !geometry.spheres.center.is_empty() {
        // Embree is given the triangles only.
        println!("   {} rays: not compared (the scene has spheres)", set.kind);
        return;
    }
    // wavepath's answers once; each Embree mode's against them.
    let (mut ours, mut occ) = set.buffers();
    trace(bvh, set, &mut ours, &mut occ);
    let (mut theirs, _) = set.buffers();
    let mut total = 0usize;
    for mode in [
        embree::Mode::Single,
        embree::Mode::Packet8,
        embree::Mode::Packet16,
    ] {
        trace_embree(escene, set, mode, &mut theirs);
        let mut differ = 0usize;
        for (b, rays) in set.batches.iter().enumerate() {
            let (ours, occ, theirs) = (&ours[b], &occ[b], &theirs[b]);
            if set.shadow {
                differ += (0..rays.len())
                    .filter(|&i| occ[i] != theirs.is_hit(i))
                    .count();
            } else {
                differ += (0..rays.len())
                    .filter(|&i| {
                        let near =
                            (ours.t[i] - theirs.t[i]).abs() <= 1e-4 * theirs.t[i].abs() + 1e-6;
                        ours.is_hit(i) != theirs.is_hit(i)
                            || (ours.is_hit(i) && ours.prim[i] != theirs.prim[i] && !near)
                    })
                    .count();
            }
        }
        total += differ;
        assert!(
            differ * 10_000 <= set.len(),
            "{} rays: wavepath and Embree ({}) disagree on {differ} of {}",
            set.kind,
            mode.name(),
            set.len()
        );
    }
    println!(
        "   {} rays: wavepath and Embree agree (all three modes; {total} ray answers differ in all)",
        set.kind
    );
}

fn pools() -> [(&'static str, rayon::ThreadPool); 2] {
    [
        (
            "1t",
            rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap(),
        ),
        ("mt", rayon::ThreadPoolBuilder::new().build().unwrap()),
    ]
}

fn bench_workload(c: &mut Criterion, w: &Workload) {
    let tris = w.geometry.triangles.len();
    println!(
        "== {}: {} triangles, {} spheres",
        w.name,
        tris,
        w.geometry.spheres.len()
    );
    let mut group = c.benchmark_group(format!("build/{}", w.name));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200));
    group.measurement_time(Duration::from_secs(2));
    group.throughput(Throughput::Elements(tris as u64));
    group.bench_function("wavepath-sah", |b| {
        b.iter(|| Bvh::build(&w.geometry, Accel::Sah))
    });
    #[cfg(feature = "embree")]
    let device = embree::Device::new();
    #[cfg(feature = "embree")]
    group.bench_function("embree", |b| {
        b.iter(|| embree::Scene::new(&device, &w.geometry))
    });
    group.finish();

    let bvh = Bvh::build(&w.geometry, Accel::Sah);
    println!(
        "   wavepath: {} nodes, depth {}, {} triangle groups, {:.1} bytes/triangle",
        bvh.node_count(),
        bvh.depth(),
        bvh.triangle_group_count(),
        bvh.memory_bytes() as f64 / tris.max(1) as f64
    );
    #[cfg(feature = "embree")]
    let escene = embree::Scene::new(&device, &w.geometry);

    let sets = ray_sets(w, &bvh);
    for set in &sets {
        let mut stats = TraversalStats::default();
        let (mut hits, mut occluded) = (Hits::default(), Vec::new());
        for rays in &set.batches {
            trace_batch(&bvh, set, rays, (&mut hits, &mut occluded), &mut stats);
        }
        println!(
            "   {} rays: {}, {:.1} nodes and {:.1} primitives per ray",
            set.kind,
            stats.rays,
            stats.nodes_visited as f64 / stats.rays.max(1) as f64,
            stats.primitives_tested as f64 / stats.rays.max(1) as f64
        );
    }
    for set in &sets {
        let (mut hits, mut occ) = set.buffers();
        #[cfg(feature = "embree")]
        check_agreement(&bvh, &escene, set, &w.geometry);
        let mut group = c.benchmark_group(format!("trace/{}/{}", w.name, set.kind));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(300));
        group.measurement_time(Duration::from_secs(1));
        group.throughput(Throughput::Elements(set.len() as u64));
        for (threads, pool) in &pools() {
            group.bench_function(BenchmarkId::new("wavepath", threads), |b| {
                b.iter(|| pool.install(|| trace(&bvh, set, &mut hits, &mut occ)))
            });
            #[cfg(feature = "embree")]
            for mode in [
                embree::Mode::Single,
                embree::Mode::Packet8,
                embree::Mode::Packet16,
            ] {
                group.bench_function(BenchmarkId::new(mode.name(), threads), |b| {
                    b.iter(|| pool.install(|| trace_embree(&escene, set, mode, &mut hits)))
                });
            }
        }
        group.finish();
    }
}

/// Build time and single-thread primary-ray throughput from 1k to 4M triangles.
fn bench_scaling(c: &mut Criterion) {
    for n in [16, 64, 256, 512, 1024] {
        let w = bumpy_sphere(n);
        let tris = w.geometry.triangles.len();
        let mut group = c.benchmark_group(format!("scaling/{}", w.name));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(100));
        group.measurement_time(Duration::from_secs(1));
        group.throughput(Throughput::Elements(tris as u64));
        group.bench_function("build", |b| b.iter(|| Bvh::build(&w.geometry, Accel::Sah)));
        let bvh = Bvh::build(&w.geometry, Accel::Sah);
        let sets = ray_sets(&w, &bvh);
        let set = &sets[0];
        let (mut hits, mut occ) = set.buffers();
        group.throughput(Throughput::Elements(set.len() as u64));
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        group.bench_function("primary-1t", |b| {
            b.iter(|| pool.install(|| trace(&bvh, set, &mut hits, &mut occ)))
        });
        group.finish();
    }
}

/// CPU time consumed by the calling thread, in nanoseconds (first field
/// of `/proc/thread-self/schedstat`); unlike wall time it is not inflated
/// when other processes compete for the cores.
fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

/// Best of `reps` measurements of `f`: (thread CPU seconds, wall seconds)
/// per call. Each measurement repeats `f` for at least 0.2 s, because the
/// kernel may account CPU time only at scheduler ticks (4 ms here).
fn best_of(reps: usize, mut f: impl FnMut()) -> (f64, f64) {
    let (mut cpu, mut wall) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..reps {
        let c0 = thread_cpu_ns();
        let t0 = std::time::Instant::now();
        let mut calls = 0;
        while calls == 0 || t0.elapsed().as_secs_f64() < 0.2 {
            f();
            calls += 1;
        }
        let w = t0.elapsed().as_secs_f64() / calls as f64;
        wall = wall.min(w);
        cpu = cpu.min(match (c0, thread_cpu_ns()) {
            (Some(a), Some(b)) => (b - a) as f64 * 1e-9 / calls as f64,
            _ => w,
        });
    }
    (cpu, wall)
}

/// `BVH_BENCH_PROFILE=<set>`: traces only the named ray set (`primary`,
/// `diffuse` or `shadow`) of each scene with wavepath, once (or
/// `BVH_BENCH_REPEAT` times), on the calling thread (or, for `build`,
/// only builds the BVH, on all threads): a run short and deterministic
/// enough for callgrind's instruction counts (which, unlike times on this
/// shared machine, can tell a 3% change apart) or `perf record`.
/// `BVH_BENCH_ENGINE=embree-1` (or `embree-8`, `embree-16`; with the
/// `embree` feature) traces the same rays with that Embree mode instead,
/// so the two engines' instructions per ray can be set side by side (an
/// x86-64-v3 build under valgrind makes Embree pick its AVX2 code too).
fn profile(w: &Workload, kind: &str) {
    let repeat: usize = std::env::var("BVH_BENCH_REPEAT")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(1);
    if kind == "build" {
        let t0 = std::time::Instant::now();
        for _ in 0..repeat {
            drop(Bvh::build(&w.geometry, Accel::Sah));
        }
        let ms = t0.elapsed().as_secs_f64() * 1e3 / repeat as f64;
        println!("{} build: {ms:.2} ms", w.name);
        return;
    }
    let bvh = Bvh::build(&w.geometry, Accel::Sah);
    let engine = std::env::var("BVH_BENCH_ENGINE").unwrap_or_else(|_| "wavepath".into());
    #[cfg(feature = "embree")]
    let embree_mode = [
        embree::Mode::Single,
        embree::Mode::Packet8,
        embree::Mode::Packet16,
    ]
    .into_iter()
    .find(|m| m.name() == engine);
    #[cfg(feature = "embree")]
    if let Some(mode) = embree_mode {
        let device = embree::Device::new();
        let escene = embree::Scene::new(&device, &w.geometry);
        for set in ray_sets(w, &bvh).iter().filter(|s| s.kind == kind) {
            let (mut hits, _) = set.buffers();
            let t0 = std::time::Instant::now();
            for _ in 0..repeat {
                for (rays, h) in set.batches.iter().zip(hits.iter_mut()) {
                    escene.trace(rays, set.shadow, kind == "primary", mode, h);
                }
            }
            let rays = (set.len() * repeat) as f64;
            let secs = t0.elapsed().as_secs_f64();
            println!(
                "{} {} ({engine}): {rays} rays, {:.2} Mrays/s",
                w.name,
                kind,
                rays * 1e-6 / secs
            );
        }
        return;
    }
    if engine != "wavepath" {
        let modes = ["embree-1", "embree-8", "embree-16"];
        if modes.contains(&engine.as_str()) {
            eprintln!("BVH_BENCH_ENGINE={engine}: Embree's modes need --features embree");
        } else {
            eprintln!(
                "BVH_BENCH_ENGINE: '{engine}' is not wavepath, {}",
                modes.join(", ")
            );
        }
        std::process::exit(2);
    }
    for set in ray_sets(w, &bvh).iter().filter(|s| s.kind == kind) {
        let t0 = std::time::Instant::now();
        let stats = trace_profiled(&bvh, set, repeat);
        let secs = t0.elapsed().as_secs_f64();
        println!(
            "{} {}: {} rays, {:.2} nodes/ray, {:.2} primitives/ray, {:.2} Mrays/s",
            w.name,
            kind,
            stats.rays,
            stats.nodes_visited as f64 / stats.rays.max(1) as f64,
            stats.primitives_tested as f64 / stats.rays.max(1) as f64,
            stats.rays as f64 * 1e-6 / secs
        );
    }
}

/// `BVH_BENCH_QUICK=1`: a plain table instead of criterion. Single-thread
/// rates use the tracing thread's CPU time (robust on a shared machine),
/// all-thread rates wall time; best of 5.
fn quick(w: &Workload) {
    let tris = w.geometry.triangles.len();
    let (_, build) = best_of(3, || drop(Bvh::build(&w.geometry, Accel::Sah)));
    let bvh = Bvh::build(&w.geometry, Accel::Sah);
    #[cfg(feature = "embree")]
    let device = embree::Device::new();
    #[cfg(feature = "embree")]
    let (_, ebuild) = best_of(3, || drop(embree::Scene::new(&device, &w.geometry)));
    #[cfg(not(feature = "embree"))]
    let ebuild = f64::NAN;
    #[cfg(feature = "embree")]
    let escene = embree::Scene::new(&device, &w.geometry);
    println!(
        "{}: {} tris, build {:.1} ms (embree {:.1} ms), {:.1} B/tri, {} nodes, depth {}",
        w.name,
        tris,
        build * 1e3,
        ebuild * 1e3,
        bvh.memory_bytes() as f64 / tris.max(1) as f64,
        bvh.node_count(),
        bvh.depth()
    );
    let all = rayon::ThreadPoolBuilder::new().build().unwrap();
    for set in &ray_sets(w, &bvh) {
        let (mut hits, mut occ) = set.buffers();
        #[cfg(feature = "embree")]
        check_agreement(&bvh, &escene, set, &w.geometry);
        let n = set.len() as f64 * 1e-6;
        let mut row = format!("  {:8} {:7} rays", set.kind, set.len());
        let (c1, _) = best_of(3, || {
            for (rays, (h, o)) in set.batches.iter().zip(hits.iter_mut().zip(occ.iter_mut())) {
                trace_batch(&bvh, set, rays, (h, o), &mut Default::default());
            }
        });
        let (_, wm) = best_of(3, || all.install(|| trace(&bvh, set, &mut hits, &mut occ)));
        row += &format!(" | wavepath {:6.1} {:6.1}", n / c1, n / wm);
        #[cfg(feature = "embree")]
        for mode in [
            embree::Mode::Single,
            embree::Mode::Packet8,
            embree::Mode::Packet16,
        ] {
            let primary = set.kind == "primary";
            let (c1, _) = best_of(3, || {
                for (rays, h) in set.batches.iter().zip(hits.iter_mut()) {
                    escene.trace(rays, set.shadow, primary, mode, h);
                }
            });
            let (_, wm) = best_of(3, || {
                all.install(|| trace_embree(&escene, set, mode, &mut hits))
            });
            row += &format!(" | {} {:6.1} {:6.1}", mode.name(), n / c1, n / wm);
        }
        println!("{row}");
    }
}

/// Waits until the workers of the pool used last have gone to sleep.
/// A rayon worker out of work spins, yielding, for a while before it
/// sleeps; with two cores, a run started at once on the other pool
/// shares a core with it. In the thread-scaling rounds the one-thread and
/// all-thread runs alternate, and without this pause wavepath's runs were
/// the ones that started right after a switch of pools (PERF.md,
/// thirteenth session).
fn settle() {
    std::thread::sleep(std::time::Duration::from_millis(20));
}

/// The median of `v` (sorted in place; NaN if empty).
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// `BVH_BENCH_PROFILE=threads`: how each ray set's trace rate grows from
/// one thread to all, for wavepath and (with the `embree` feature) each of
/// Embree's modes, all timed in wall clock, alternating, nine rounds each;
/// medians. Tells a gap between the quick table's one- and all-thread
/// ratios apart from noise, and gives the all-thread ratio to Embree's
/// best mode from interleaved runs.
fn thread_scaling(w: &Workload) {
    let bvh = Bvh::build(&w.geometry, Accel::Sah);
    #[cfg(feature = "embree")]
    let device = embree::Device::new();
    #[cfg(feature = "embree")]
    let escene = embree::Scene::new(&device, &w.geometry);
    #[cfg(feature = "embree")]
    let modes = [
        embree::Mode::Single,
        embree::Mode::Packet8,
        embree::Mode::Packet16,
    ];
    #[cfg(not(feature = "embree"))]
    let modes: [(); 0] = [];
    let [(_, one), (_, all)] = pools();
    for set in &ray_sets(w, &bvh) {
        let (mut hits, mut occ) = set.buffers();
        let n = set.len() as f64 * 1e-6;
        // rates[engine][pool]: engine 0 is wavepath, then Embree's modes.
        let mut rates = vec![[Vec::new(), Vec::new()]; 1 + modes.len()];
        for _ in 0..9 {
            for (k, pool) in [&one, &all].into_iter().enumerate() {
                settle();
                let (_, wall) =
                    best_of(1, || pool.install(|| trace(&bvh, set, &mut hits, &mut occ)));
                rates[0][k].push(n / wall);
                #[cfg(feature = "embree")]
                for (m, &mode) in modes.iter().enumerate() {
                    settle();
                    let (_, wall) = best_of(1, || {
                        pool.install(|| trace_embree(&escene, set, mode, &mut hits))
                    });
                    rates[1 + m][k].push(n / wall);
                }
            }
        }
        let medians: Vec<[f64; 2]> = rates
            .iter_mut()
            .map(|r| r.each_mut().map(|v| median(v)))
            .collect();
        let mut row = format!("{} {:8} Mrays/s 1t → all:", w.name, set.kind);
        #[cfg(feature = "embree")]
        let names: Vec<&str> = std::iter::once("wavepath")
            .chain(modes.iter().map(|m| m.name()))
            .collect();
        #[cfg(not(feature = "embree"))]
        let names = ["wavepath"];
        for (name, [r1, rn]) in names.iter().zip(&medians) {
            row += &format!(" | {name} {r1:6.1} → {rn:6.1} ({:.2}×)", rn / r1);
        }
        if medians.len() > 1 {
            let best = |k: usize| medians[1..].iter().map(|m| m[k]).fold(0.0, f64::max);
            row += &format!(
                " | vs best: 1t {:.2}, all {:.2}",
                medians[0][0] / best(0),
                medians[0][1] / best(1)
            );
        }
        println!("{row}");
    }
}

/// `BVH_BENCH_PROFILE=batches`: wavepath's trace of each set repeated
/// back to back for 0.3 s on one thread and on all, with every batch
/// timed. Per pool: the mean wall time per trace, the threads' busy share
/// of it (what the rest is: the pool's wake-up and the tail of the last
/// batches, a fixed cost per trace), and the median and longest batch (a
/// longest batch of ~4 ms, one scheduler tick, is the core taken away
/// mid-batch). Both explain why threads-mode figures of short traces are
/// the noisiest (PERF.md, targets), whichever engine is timed.
fn batch_times(w: &Workload) {
    let bvh = Bvh::build(&w.geometry, Accel::Sah);
    let pools = pools();
    for set in &ray_sets(w, &bvh) {
        let (mut hits, mut occ) = set.buffers();
        let mut seconds = vec![0.0f64; set.batches.len()];
        for (name, pool) in &pools {
            settle();
            let (mut traces, mut wall, mut busy) = (0, 0.0, 0.0);
            let mut all = Vec::new();
            let t0 = std::time::Instant::now();
            while t0.elapsed().as_secs_f64() < 0.3 {
                let start = std::time::Instant::now();
                pool.install(|| {
                    set.batches
                        .par_iter()
                        .with_max_len(1)
                        .zip(hits.par_iter_mut().zip(occ.par_iter_mut()))
                        .zip(seconds.par_iter_mut())
                        .for_each(|((rays, (h, o)), secs)| {
                            let b0 = std::time::Instant::now();
                            trace_batch(&bvh, set, rays, (h, o), &mut Default::default());
                            *secs = b0.elapsed().as_secs_f64();
                        });
                });
                wall += start.elapsed().as_secs_f64();
                busy += seconds.iter().sum::<f64>();
                all.extend_from_slice(&seconds);
                traces += 1;
            }
            let threads = pool.current_num_threads() as f64;
            let batch_median = median(&mut all); // sorts `all`
            let longest = all.last().copied().unwrap_or(0.0);
            println!(
                "{} {:8} {name}: {traces} traces, {:.3} ms each, threads busy {:.0}%, \
                 batch median {:.3} ms, longest {:.3} ms",
                w.name,
                set.kind,
                wall * 1e3 / traces as f64,
                busy / (wall * threads) * 100.0,
                batch_median * 1e3,
                longest * 1e3,
            );
        }
    }
}

/// How this machine itself scales from one thread to all, printed before
/// and after the scenes in `BVH_BENCH_PROFILE=threads`: a trace's
/// one-to-all ratio means little without it, and on a shared VM it changes
/// from hour to hour. Two synthetic kernels of 16-lane fused
/// multiply-adds, run once per thread of the pool (`broadcast`), alternating,
/// nine rounds, medians: one dependent chain (bound by the FMA's latency)
/// and sixteen independent chains (bound by FMA throughput). Both scale by
/// the thread count on cores that are the run's own; when they do not, the
/// host is busy and the traces' all-thread figures are depressed too (the
/// throughput-bound kernel is the more sensitive: 1.1–1.9× in the noisy
/// start of the fifteenth session, 1.94–1.99× later; PERF.md).
fn machine_scaling(when: &str) {
    fn kernel<const CHAINS: usize>(iterations: u32) -> f32 {
        // Opaque constants, so the loop cannot be folded away.
        let m = std::hint::black_box(wide::f32x16::splat(0.999_999));
        let c = std::hint::black_box(wide::f32x16::splat(1e-7));
        let mut x = [wide::f32x16::splat(1.0); CHAINS];
        for _ in 0..iterations {
            for v in &mut x {
                *v = v.mul_add(m, c);
            }
        }
        x.iter().map(|v| v.reduce_add()).sum()
    }
    let [(_, one), (_, all)] = pools();
    type Kernel = fn() -> f32;
    let kernels: [(&str, Kernel); 2] = [
        ("latency-bound (1 FMA chain)", || kernel::<1>(100_000_000)),
        ("throughput-bound (16 FMA chains)", || {
            kernel::<16>(50_000_000)
        }),
    ];
    for (name, run) in kernels {
        let mut rates = [Vec::new(), Vec::new()];
        for _ in 0..9 {
            for (k, pool) in [&one, &all].into_iter().enumerate() {
                settle();
                let t0 = std::time::Instant::now();
                let sums = pool.broadcast(|_| run());
                let wall = t0.elapsed().as_secs_f64();
                std::hint::black_box(sums);
                rates[k].push(pool.current_num_threads() as f64 / wall);
            }
        }
        let [r1, rn] = rates.each_mut().map(|v| median(v));
        println!("machine at {when}, {name}: 1t → all {:.2}×", rn / r1);
    }
}

/// The traces of [`profile`], in a function of their own so that a
/// profiler can count them alone: building the ray sets traces the
/// primary rays too (to find the surfaces the other sets start from).
/// For callgrind: `--toggle-collect='bvh::trace_profiled'`.
#[inline(never)]
fn trace_profiled(bvh: &Bvh, set: &RaySet, repeat: usize) -> TraversalStats {
    let mut stats = TraversalStats::default();
    // Result buffers reused from batch to batch, as the renderer does.
    let (mut hits, mut occluded) = (Hits::default(), Vec::new());
    for rays in std::iter::repeat_n(&set.batches, repeat).flatten() {
        trace_batch(bvh, set, rays, (&mut hits, &mut occluded), &mut stats);
    }
    stats
}

/// Loads each CS184 scene of the benchmark that `BVH_BENCH_SCENES` asks
/// for (all by default) and hands it to `run`.
fn for_each_cs184_scene(mut run: impl FnMut(&Workload)) {
    for (name, rel) in [
        ("CBbunny", "sky/CBbunny.dae"),
        ("maxplanck", "meshedit/maxplanck.dae"),
        ("building", "keenan/building.dae"),
    ] {
        if wanted(name)
            && let Some(w) = load(name, rel)
        {
            run(&w);
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let profiled = std::env::var("BVH_BENCH_PROFILE").ok();
    if std::env::var_os("BVH_BENCH_QUICK").is_some() || profiled.is_some() {
        let threads = profiled.as_deref() == Some("threads");
        if threads {
            machine_scaling("start");
        }
        let run = |w: &Workload| match profiled.as_deref() {
            Some("threads") => thread_scaling(w),
            Some("batches") => batch_times(w),
            Some(kind) => profile(w, kind),
            None => quick(w),
        };
        for_each_cs184_scene(&run);
        for n in [16, 64, 256, 512, 1024] {
            if wanted(&sphere_name(n)) {
                run(&bumpy_sphere(n));
            }
        }
        if threads {
            machine_scaling("end");
        }
        return;
    }
    if std::env::var_os("BVH_BENCH_SCALING").is_some() {
        bench_scaling(&mut c);
    } else {
        let dir = scenes_dir();
        if !dir.is_dir() {
            println!("skipping the CS184 scenes: {} not found", dir.display());
        }
        for_each_cs184_scene(|w| bench_workload(&mut c, w));
        for (name, n) in [("sphere1M", 512), ("sphere4M", 1024)] {
            if wanted(name) {
                bench_workload(&mut c, &bumpy_sphere(n));
            }
        }
    }
    c.final_summary();
}

/// Hand-written bindings to the few Embree 3 calls the benchmark needs.
#[cfg(feature = "embree")]
mod embree {
    use std::ffi::{c_char, c_void};
    use std::ptr;

    use wavepath::ray::{Hits, NO_HIT, Rays};
    use wavepath::scene::Geometry;

    const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
    const RTC_BUFFER_TYPE_INDEX: u32 = 0;
    const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
    const RTC_FORMAT_UINT3: u32 = 0x5003;
    const RTC_FORMAT_FLOAT3: u32 = 0x9003;
    const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: u32 = 0;
    const RTC_INTERSECT_CONTEXT_FLAG_COHERENT: u32 = 1;
    const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
    const RTC_SCENE_FLAG_ROBUST: u32 = 1 << 2;

    #[repr(C)]
    struct RTCIntersectContext {
        flags: u32,
        filter: *const c_void,
        inst_id: [u32; 1],
    }

    #[repr(C, align(16))]
    #[derive(Default, Clone, Copy)]
    struct RTCRay {
        org: [f32; 3],
        tnear: f32,
        dir: [f32; 3],
        time: f32,
        tfar: f32,
        mask: u32,
        id: u32,
        flags: u32,
    }

    #[repr(C, align(16))]
    #[derive(Default, Clone, Copy)]
    struct RTCHit {
        ng: [f32; 3],
        u: f32,
        v: f32,
        prim_id: u32,
        geom_id: u32,
        inst_id: [u32; 1],
    }

    #[repr(C)]
    #[derive(Default, Clone, Copy)]
    struct RTCRayHit {
        ray: RTCRay,
        hit: RTCHit,
    }

    /// `RTCRayHit8` / `RTCRayHit16`: SoA packets of N rays (12 ray arrays,
    /// then 8 hit arrays). Alignment 32 suffices for 8; 64 for 16.
    #[repr(C, align(64))]
    #[derive(Clone, Copy)]
    struct RayHitN<const N: usize> {
        org: [[f32; N]; 3],
        tnear: [f32; N],
        dir: [[f32; N]; 3],
        time: [f32; N],
        tfar: [f32; N],
        mask: [u32; N],
        id: [u32; N],
        flags: [u32; N],
        ng: [[f32; N]; 3],
        u: [f32; N],
        v: [f32; N],
        prim_id: [u32; N],
        geom_id: [u32; N],
        inst_id: [u32; N],
    }

    #[link(name = "embree3")]
    unsafe extern "C" {
        fn rtcNewDevice(config: *const c_char) -> *mut c_void;
        fn rtcReleaseDevice(device: *mut c_void);
        fn rtcNewScene(device: *mut c_void) -> *mut c_void;
        fn rtcSetSceneFlags(scene: *mut c_void, flags: u32);
        fn rtcReleaseScene(scene: *mut c_void);
        fn rtcNewGeometry(device: *mut c_void, ty: u32) -> *mut c_void;
        fn rtcSetNewGeometryBuffer(
            geometry: *mut c_void,
            ty: u32,
            slot: u32,
            format: u32,
            byte_stride: usize,
            count: usize,
        ) -> *mut c_void;
        fn rtcCommitGeometry(geometry: *mut c_void);
        fn rtcAttachGeometry(scene: *mut c_void, geometry: *mut c_void) -> u32;
        fn rtcReleaseGeometry(geometry: *mut c_void);
        fn rtcCommitScene(scene: *mut c_void);
        fn rtcIntersect1(scene: *mut c_void, ctx: *mut RTCIntersectContext, rayhit: *mut RTCRayHit);
        fn rtcOccluded1(scene: *mut c_void, ctx: *mut RTCIntersectContext, ray: *mut RTCRay);
        fn rtcIntersect8(
            valid: *const i32,
            scene: *mut c_void,
            ctx: *mut RTCIntersectContext,
            rayhit: *mut RayHitN<8>,
        );
        fn rtcOccluded8(
            valid: *const i32,
            scene: *mut c_void,
            ctx: *mut RTCIntersectContext,
            ray: *mut RayHitN<8>,
        );
        fn rtcIntersect16(
            valid: *const i32,
            scene: *mut c_void,
            ctx: *mut RTCIntersectContext,
            rayhit: *mut RayHitN<16>,
        );
        fn rtcOccluded16(
            valid: *const i32,
            scene: *mut c_void,
            ctx: *mut RTCIntersectContext,
            ray: *mut RayHitN<16>,
        );
    }

    pub struct Device(*mut c_void);

    // SAFETY: Embree devices and committed scenes are thread safe for queries.
    unsafe impl Send for Device {}
    unsafe impl Sync for Device {}

    impl Device {
        pub fn new() -> Device {
            // `BVH_BENCH_EMBREE_CONFIG` (e.g. "verbose=2", which prints
            // Embree's BVH statistics) is passed through; unset selects the
            // defaults.
            let config = std::env::var("BVH_BENCH_EMBREE_CONFIG").ok().map(|c| {
                std::ffi::CString::new(c).expect("BVH_BENCH_EMBREE_CONFIG holds a NUL byte")
            });
            let config_ptr = config.as_ref().map_or(ptr::null(), |c| c.as_ptr());
            // SAFETY: a null or NUL-terminated config string, alive for the call.
            let d = unsafe { rtcNewDevice(config_ptr) };
            assert!(!d.is_null(), "rtcNewDevice failed");
            Device(d)
        }
    }

    impl Drop for Device {
        fn drop(&mut self) {
            // SAFETY: the device outlives every scene (scenes borrow it).
            unsafe { rtcReleaseDevice(self.0) }
        }
    }

    pub struct Scene(*mut c_void);

    // SAFETY: a committed scene is immutable and Embree allows concurrent queries.
    unsafe impl Send for Scene {}
    unsafe impl Sync for Scene {}

    #[derive(Clone, Copy, Debug)]
    pub enum Mode {
        Single,
        Packet8,
        Packet16,
    }

    impl Mode {
        pub fn name(self) -> &'static str {
            match self {
                Mode::Single => "embree-1",
                Mode::Packet8 => "embree-8",
                Mode::Packet16 => "embree-16",
            }
        }
    }

    impl Scene {
        /// Builds an Embree scene over the triangles of `g` (default quality;
        /// with `BVH_BENCH_EMBREE_ROBUST` set (not to 0), Embree's robust mode: its
        /// conservative box and watertight triangle tests, which wavepath's
        /// walk always does).
        pub fn new(device: &Device, g: &Geometry) -> Scene {
            let t = &g.triangles;
            // SAFETY: buffers are allocated by Embree with the sizes given and
            // filled within those bounds before commit.
            unsafe {
                let scene = rtcNewScene(device.0);
                if std::env::var("BVH_BENCH_EMBREE_ROBUST").is_ok_and(|v| !v.is_empty() && v != "0")
                {
                    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
                }
                let geom = rtcNewGeometry(device.0, RTC_GEOMETRY_TYPE_TRIANGLE);
                let v = rtcSetNewGeometryBuffer(
                    geom,
                    RTC_BUFFER_TYPE_VERTEX,
                    0,
                    RTC_FORMAT_FLOAT3,
                    12,
                    t.positions.len(),
                ) as *mut [f32; 3];
                for (i, p) in t.positions.iter().enumerate() {
                    *v.add(i) = p.to_array();
                }
                let idx = rtcSetNewGeometryBuffer(
                    geom,
                    RTC_BUFFER_TYPE_INDEX,
                    0,
                    RTC_FORMAT_UINT3,
                    12,
                    t.indices.len(),
                ) as *mut [u32; 3];
                ptr::copy_nonoverlapping(t.indices.as_ptr(), idx, t.indices.len());
                rtcCommitGeometry(geom);
                rtcAttachGeometry(scene, geom);
                rtcReleaseGeometry(geom);
                rtcCommitScene(scene);
                Scene(scene)
            }
        }

        /// Traces a batch; closest hits go to `hits.prim`/`hits.t`, any-hit
        /// results to `hits.prim` (0 = occluded).
        pub fn trace(
            &self,
            rays: &Rays,
            shadow: bool,
            coherent: bool,
            mode: Mode,
            hits: &mut Hits,
        ) {
            let n = rays.len();
            hits.reset(n);
            let mut ctx = RTCIntersectContext {
                flags: if coherent {
                    RTC_INTERSECT_CONTEXT_FLAG_COHERENT
                } else {
                    RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
                },
                filter: ptr::null(),
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            };
            match mode {
                Mode::Single => {
                    for i in 0..n {
                        let mut rh = RTCRayHit {
                            ray: RTCRay {
                                org: [rays.org_x[i], rays.org_y[i], rays.org_z[i]],
                                dir: [rays.dir_x[i], rays.dir_y[i], rays.dir_z[i]],
                                tfar: rays.t_max[i],
                                mask: u32::MAX,
                                ..Default::default()
                            },
                            hit: RTCHit {
                                geom_id: RTC_INVALID_GEOMETRY_ID,
                                ..Default::default()
                            },
                        };
                        // SAFETY: valid scene, context and ray structures.
                        unsafe {
                            if shadow {
                                rtcOccluded1(self.0, &mut ctx, &mut rh.ray);
                                hits.prim[i] = if rh.ray.tfar < 0.0 { 0 } else { NO_HIT };
                            } else {
                                rtcIntersect1(self.0, &mut ctx, &mut rh);
                                if rh.hit.geom_id != RTC_INVALID_GEOMETRY_ID {
                                    hits.prim[i] = rh.hit.prim_id;
                                    hits.t[i] = rh.ray.tfar;
                                }
                            }
                        }
                    }
                }
                Mode::Packet8 => self.packets::<8>(rays, shadow, &mut ctx, hits),
                Mode::Packet16 => self.packets::<16>(rays, shadow, &mut ctx, hits),
            }
        }

        fn packets<const N: usize>(
            &self,
            rays: &Rays,
            shadow: bool,
            ctx: &mut RTCIntersectContext,
            hits: &mut Hits,
        ) {
            let n = rays.len();
            let mut p: RayHitN<N> = RayHitN {
                org: [[0.0; N]; 3],
                tnear: [0.0; N],
                dir: [[0.0; N]; 3],
                time: [0.0; N],
                tfar: [0.0; N],
                mask: [u32::MAX; N],
                id: [0; N],
                flags: [0; N],
                ng: [[0.0; N]; 3],
                u: [0.0; N],
                v: [0.0; N],
                prim_id: [0; N],
                geom_id: [RTC_INVALID_GEOMETRY_ID; N],
                inst_id: [RTC_INVALID_GEOMETRY_ID; N],
            };
            /// The valid mask must be aligned like the packet.
            #[repr(C, align(64))]
            struct Valid<const N: usize>([i32; N]);
            for start in (0..n).step_by(N) {
                let mut valid = Valid([0i32; N]);
                for l in 0..N.min(n - start) {
                    let i = start + l;
                    valid.0[l] = -1;
                    p.org[0][l] = rays.org_x[i];
                    p.org[1][l] = rays.org_y[i];
                    p.org[2][l] = rays.org_z[i];
                    p.dir[0][l] = rays.dir_x[i];
                    p.dir[1][l] = rays.dir_y[i];
                    p.dir[2][l] = rays.dir_z[i];
                    p.tfar[l] = rays.t_max[i];
                    p.geom_id[l] = RTC_INVALID_GEOMETRY_ID;
                }
                // SAFETY: packet and valid mask are correctly sized and aligned.
                unsafe {
                    match (N, shadow) {
                        (8, false) => rtcIntersect8(
                            valid.0.as_ptr(),
                            self.0,
                            ctx,
                            &mut p as *mut _ as *mut RayHitN<8>,
                        ),
                        (8, true) => rtcOccluded8(
                            valid.0.as_ptr(),
                            self.0,
                            ctx,
                            &mut p as *mut _ as *mut RayHitN<8>,
                        ),
                        (16, false) => rtcIntersect16(
                            valid.0.as_ptr(),
                            self.0,
                            ctx,
                            &mut p as *mut _ as *mut RayHitN<16>,
                        ),
                        _ => rtcOccluded16(
                            valid.0.as_ptr(),
                            self.0,
                            ctx,
                            &mut p as *mut _ as *mut RayHitN<16>,
                        ),
                    }
                }
                for l in 0..N.min(n - start) {
                    let i = start + l;
                    if shadow {
                        hits.prim[i] = if p.tfar[l] < 0.0 { 0 } else { NO_HIT };
                    } else if p.geom_id[l] != RTC_INVALID_GEOMETRY_ID {
                        hits.prim[i] = p.prim_id[l];
                        hits.t[i] = p.tfar[l];
                    }
                }
            }
        }
    }

    impl Drop for Scene {
        fn drop(&mut self) {
            // SAFETY: releasing our own reference.
            unsafe { rtcReleaseScene(self.0) }
        }
    }
}
