//! Building scenes in code and rendering them, for estimator tests.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::{Mat3, Vec3};
use wavepath::bvh::{Accel, Bvh};
use wavepath::film::Image;
use wavepath::scene::{Camera, Geometry, Light, Material, NamedMaterial, Scene};
use wavepath::wavefront::{RenderOutput, RenderSettings, Renderer};

/// A pinhole camera at `position` looking along `forward`, with vertical
/// field of view `vfov` degrees for an image `height` pixels tall.
pub fn camera(position: Vec3, forward: Vec3, up: Vec3, vfov: f32, height: u32) -> Camera {
    let back = -forward.normalize();
    let x = up.cross(back).normalize();
    let y = back.cross(x);
    Camera {
        position,
        target: position + forward,
        camera_to_world: Mat3::from_cols(x, y, back),
        screen_distance: 0.5 * height as f32 / (0.5 * vfov.to_radians()).tan(),
        znear: 0.0,
        zfar: 1e30,
    }
}

/// Scene assembly with named materials.
#[derive(Default)]
pub struct Builder {
    pub geometry: Geometry,
    pub materials: Vec<NamedMaterial>,
    pub lights: Vec<Light>,
}

impl Builder {
    pub fn material(&mut self, material: Material) -> u32 {
        self.materials.push(NamedMaterial {
            name: format!("m{}", self.materials.len()),
            material,
        });
        self.materials.len() as u32 - 1
    }

    pub fn triangle(&mut self, a: Vec3, b: Vec3, c: Vec3, material: u32) {
        let t = &mut self.geometry.triangles;
        let base = t.positions.len() as u32;
        let n = (b - a).cross(c - a).normalize();
        t.positions.extend_from_slice(&[a, b, c]);
        t.normals.extend_from_slice(&[n, n, n]);
        t.indices.push([base, base + 1, base + 2]);
        t.material.push(material);
    }

    /// Quad a-b-c-d as two triangles.
    pub fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, material: u32) {
        self.triangle(a, b, c, material);
        self.triangle(a, c, d, material);
    }

    /// A square floor in the plane y = 0, from −`half` to `half` in x and
    /// z, facing +y.
    pub fn floor(&mut self, half: f32, material: u32) {
        let s = half;
        self.quad(
            Vec3::new(-s, 0.0, -s),
            Vec3::new(-s, 0.0, s),
            Vec3::new(s, 0.0, s),
            Vec3::new(s, 0.0, -s),
            material,
        );
    }

    pub fn sphere(&mut self, center: Vec3, radius: f32, material: u32) {
        let s = &mut self.geometry.spheres;
        s.center.push(center);
        s.radius.push(radius);
        s.material.push(material);
    }

    pub fn build(self, camera: Camera) -> Scene {
        Scene::assemble(
            self.geometry,
            self.materials,
            self.lights,
            camera,
            Vec::new(),
        )
    }
}

/// Renders on a pool of `threads` threads and checks that no pixel is NaN
/// or infinite, and that the progress reported adds up to the whole work.
pub fn render(scene: &Scene, settings: &RenderSettings, threads: usize) -> Image {
    render_reporting(scene, settings, threads).0
}

/// [`render`], also returning the progress reports in the order they came.
pub fn render_reporting(
    scene: &Scene,
    settings: &RenderSettings,
    threads: usize,
) -> (Image, Vec<u64>) {
    let (out, reports) = render_until(scene, settings, threads, usize::MAX);
    assert!(out.complete);
    assert_eq!(
        reports.iter().sum::<u64>(),
        Renderer::progress_total(settings),
        "the progress reported is not the whole work"
    );
    (out.image, reports)
}

/// Renders on a pool of `threads` threads, as Ctrl-C would stop it once
/// `passes` tile passes have reported their progress; returns the output
/// (no pixel NaN or infinite) and the reports.
pub fn render_until(
    scene: &Scene,
    settings: &RenderSettings,
    threads: usize,
    passes: usize,
) -> (RenderOutput, Vec<u64>) {
    let bvh = Bvh::build(&scene.geometry, Accel::Sah);
    let renderer = Renderer::new(scene, &bvh);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let cancel = AtomicBool::new(false);
    let reports = Mutex::new(Vec::new());
    let on_progress = |units: u64| {
        let mut reports = reports.lock().unwrap();
        reports.push(units);
        if reports.len() >= passes {
            cancel.store(true, Ordering::Relaxed);
        }
    };
    let out = pool.install(|| renderer.render(settings, &on_progress, &cancel));
    assert_eq!(
        out.image.non_finite_count(),
        0,
        "a rendered pixel is NaN or infinite"
    );
    (out, reports.into_inner().unwrap())
}

/// World-space ray direction through the centre of pixel (x, row) (row 0 at the top).
pub fn pixel_ray(scene: &Scene, width: u32, height: u32, x: u32, row: u32) -> Vec3 {
    let view = scene.camera.view(width, height);
    let y = height - 1 - row;
    scene
        .camera
        .direction(&view, x as f32 + 0.5, y as f32 + 0.5)
}

/// The mean of `f` over the part of the floor (the plane y = 0) each
/// pixel sees (see [`pixel_mean`]).
pub fn pixel_average(scene: &Scene, w: u32, h: u32, f: impl Fn(Vec3) -> f64) -> Vec<f64> {
    let o = scene.camera.position;
    pixel_mean(scene, w, h, |d| f(o + (-o.y / d.y) * d))
}

/// The mean of `f` over the camera ray directions through each pixel, by
/// an 8×8 midpoint grid within the pixel: what a film that jitters its
/// samples uniformly over the pixel converges to. (Evaluating `f` at the
/// pixel centre instead misses by ~2e-4 of the value where `f` curves,
/// which the low-variance estimates here resolve.)
pub fn pixel_mean(scene: &Scene, w: u32, h: u32, f: impl Fn(Vec3) -> f64) -> Vec<f64> {
    const N: u32 = 8;
    let view = scene.camera.view(w, h);
    let mut out = Vec::with_capacity((w * h) as usize);
    for row in 0..h {
        let y = h - 1 - row;
        for x in 0..w {
            let mut sum = 0.0;
            for j in 0..N {
                for i in 0..N {
                    let d = scene.camera.direction(
                        &view,
                        x as f32 + (i as f32 + 0.5) / N as f32,
                        y as f32 + (j as f32 + 0.5) / N as f32,
                    );
                    sum += f(d);
                }
            }
            out.push(sum / (N * N) as f64);
        }
    }
    out
}

/// Mean and standard error of the mean of `values`.
pub fn mean_and_standard_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Asserts that `estimates − expected`, pixel by pixel, averages to zero:
/// |mean residual| ≤ z·(standard error) + `slack`·|mean expected|.
///
/// Pixels use independent random streams, so the residuals are independent
/// and their mean is normal by the central limit theorem; z = 4.5 makes a
/// false failure a one-in-150,000 event.
pub fn assert_unbiased(what: &str, estimates: &[f64], expected: &[f64], slack: f64) {
    const Z: f64 = 4.5;
    let residuals: Vec<f64> = estimates.iter().zip(expected).map(|(e, x)| e - x).collect();
    let (mean, se) = mean_and_standard_error(&residuals);
    let scale = expected.iter().sum::<f64>() / expected.len() as f64;
    eprintln!(
        "{what}: mean expected {scale:.5}, mean residual {mean:.3e}, standard error {se:.3e}"
    );
    assert!(
        mean.abs() <= Z * se + slack * scale.abs(),
        "{what}: mean residual {mean:.4e} exceeds {Z}·{se:.3e} + {slack}·{scale:.4} (biased estimator)"
    );
}

/// Irradiance at `x` (normal `n`) from a Lambertian polygon of unit
/// radiance, by Lambert's exact formula:
/// E = ½ Σ_i angle(u_i, u_{i+1}) · n·normalize(u_i × u_{i+1}).
pub fn polygon_irradiance(x: Vec3, n: Vec3, polygon: &[Vec3]) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..polygon.len() {
        let a = (polygon[i] - x).normalize().as_dvec3();
        let b = (polygon[(i + 1) % polygon.len()] - x)
            .normalize()
            .as_dvec3();
        let angle = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += angle * n.as_dvec3().dot(a.cross(b).normalize());
    }
    (0.5 * sum).abs()
}

/// One colour channel (0 = R, 1 = G, 2 = B) of an image, as f64.
pub fn channel(image: &Image, c: usize) -> Vec<f64> {
    image.pixels.iter().map(|p| p[c] as f64).collect()
}
