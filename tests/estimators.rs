//! The estimators against closed-form answers.
//!
//! Each test renders a scene whose radiance is known exactly at every pixel
//! and checks that the mean residual is zero within a 4.5σ confidence
//! interval (see `common::render::assert_unbiased`). Every render also
//! asserts that no pixel is NaN or infinite.

mod common;

use std::f64::consts::PI;

use common::render::*;
use glam::Vec3;
use wavepath::film::Image;
use wavepath::film::adaptive::Adaptive;
use wavepath::integrator::{Bounces, Settings, View};
use wavepath::scene::{Light, Material, Scene};
use wavepath::wavefront::RenderSettings;

const ALBEDO: f32 = 0.5;

fn settings(width: u32, height: u32, spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width,
        height,
        spp,
        seed: 7,
        integrator: Settings {
            max_depth,
            ..Settings::default()
        },
        ..RenderSettings::default()
    }
}

/// Inside a diffuse sphere of radius 1 and albedo ρ with a point light of
/// intensity I at its centre. Every wall point gets E₀ = I/R² directly, and
/// since a sphere's interior form factors are uniform, every further bounce
/// is uniform too and multiplies by ρ: L = (ρ I / π R²) Σ_{k<m} ρ^k.
fn furnace() -> Scene {
    let mut b = Builder::default();
    let wall = b.material(Material::Diffuse {
        albedo: Vec3::splat(ALBEDO),
    });
    b.sphere(Vec3::ZERO, 1.0, wall);
    b.lights.push(Light::Point {
        position: Vec3::ZERO,
        intensity: Vec3::splat(std::f32::consts::PI),
    });
    b.build(camera(
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.3, 0.2, -1.0),
        Vec3::Y,
        60.0,
        18,
    ))
}

/// Radiance of bounce k (k ≥ 1) in the furnace: (ρ I / π) ρ^(k−1) with I = π.
fn furnace_bounce(k: u32) -> f64 {
    ALBEDO as f64 * (ALBEDO as f64).powi(k as i32 - 1)
}

/// What `--bounces` shows at `-m m` of light whose bounce k brings
/// `bounce(k)` (k ≥ 1; nothing here is seen directly).
fn shown(bounces: Bounces, m: u32, bounce: impl Fn(u32) -> f64) -> f64 {
    match bounces {
        Bounces::Accumulate => (1..=m).map(bounce).sum(),
        Bounces::Last => bounce(m),
        Bounces::Indirect => (2..=m).map(bounce).sum(),
    }
}

#[test]
fn furnace_direct_lighting_is_exact() {
    let scene = furnace();
    let image = render(&scene, &settings(16, 12, 1, 1), 2);
    let expected = furnace_bounce(1);
    for p in &image.pixels {
        assert!(
            ((p.y as f64) - expected).abs() < 1e-4 * expected,
            "{p} vs {expected}"
        );
    }
}

#[test]
fn furnace_global_illumination_matches_the_geometric_series() {
    let scene = furnace();
    // Roulette from depth 1 (it plays at vertices 1..=3 for -m 5, 1..=10
    // for -m 12), from the default depth 5 (vertices 5..=10 for -m 12), and
    // off.
    for (m, rr, from) in [(5, true, 1), (12, true, 1), (12, true, 5), (12, false, 5)] {
        let mut s = settings(24, 18, 32, m);
        s.integrator.russian_roulette = rr;
        s.integrator.roulette_depth = from;
        let image = render(&scene, &s, 2);
        let expected = shown(Bounces::Accumulate, m, furnace_bounce);
        let est = channel(&image, 1);
        assert_unbiased(
            &format!("furnace -m {m} roulette {rr} from depth {from}"),
            &est,
            &vec![expected; est.len()],
            1e-4,
        );
    }
}

#[test]
fn furnace_bounce_selection() {
    let scene = furnace();
    let m = 4;
    for bounces in [Bounces::Last, Bounces::Indirect] {
        let expected = shown(bounces, m, furnace_bounce);
        let mut s = settings(24, 18, 32, m);
        s.integrator.bounces = bounces;
        let est = channel(&render(&scene, &s, 2), 1);
        assert_unbiased(
            &format!("furnace {bounces:?}"),
            &est,
            &vec![expected; est.len()],
            1e-4,
        );
    }
}

/// The sphere furnace with the point light off centre, at `c`, and a
/// coloured albedo ρ. A wall point x (|x| = 1, inward normal −x) at
/// distance d from the light gets E₁ = I·cosθ/d² = I·(1 − x·c)/d³, so the
/// first bounce is ρ(1 − x·c)/d³ with I = π: it varies over the wall by a
/// factor of sixteen. From the second bounce on the light is uniform
/// again, because between any two points of a sphere cosθ·cosθ′/r² =
/// 1/4R²: E₂(y) = ∫ L₁ dA / 4R² = (ρ/π)·Φ / 4R² with Φ = 4πI, i.e.
/// ρI/R², so bounce k ≥ 2 brings exactly ρᵏ. Here
/// (unlike the centred furnace) where the BSDF sends a path decides what
/// it brings, and roulette weighs unequal channels.
fn off_centre_furnace(light: Vec3, albedo: Vec3) -> Scene {
    let mut b = Builder::default();
    let wall = b.material(Material::Diffuse { albedo });
    b.sphere(Vec3::ZERO, 1.0, wall);
    b.lights.push(Light::Point {
        position: light,
        intensity: Vec3::splat(std::f32::consts::PI),
    });
    b.build(camera(
        Vec3::new(-0.2, 0.1, 0.1),
        Vec3::new(0.8, 0.1, -0.6),
        Vec3::Y,
        70.0,
        18,
    ))
}

/// (1 − x·c)/d³ (the first bounce over ρ) averaged over the wall points x
/// each pixel sees, with the light at `c`.
fn off_centre_first_bounce(scene: &Scene, c: Vec3, w: u32, h: u32) -> Vec<f64> {
    let o = scene.camera.position.as_dvec3();
    let c = c.as_dvec3();
    pixel_mean(scene, w, h, |d| {
        let d = d.as_dvec3().normalize();
        let b = o.dot(d);
        let x = o + (-b + (b * b - o.length_squared() + 1.0).sqrt()) * d;
        (1.0 - x.dot(c)) / (x - c).length().powi(3)
    })
}

#[test]
fn off_centre_furnace_matches_its_closed_form() {
    let (c, albedo) = (Vec3::new(0.6, 0.0, 0.0), Vec3::new(0.8, 0.5, 0.2));
    let scene = off_centre_furnace(c, albedo);
    let (w, h) = (32, 24);
    let first = off_centre_first_bounce(&scene, c, w, h);
    // (-m, bounces shown, roulette from vertex; 0 = off, spp)
    for (m, bounces, roulette, spp) in [
        (1, Bounces::Accumulate, 0, 16),
        (2, Bounces::Last, 0, 64),
        (12, Bounces::Accumulate, 1, 64),
        (12, Bounces::Indirect, 0, 64),
    ] {
        let mut s = settings(w, h, spp, m);
        s.integrator.bounces = bounces;
        s.integrator.russian_roulette = roulette > 0;
        s.integrator.roulette_depth = roulette;
        let image = render(&scene, &s, 2);
        for (channel_index, rho) in albedo.to_array().into_iter().enumerate() {
            let rho = rho as f64;
            let expected: Vec<f64> = first
                .iter()
                .map(|&e1| {
                    shown(bounces, m, |k| {
                        if k == 1 { rho * e1 } else { rho.powi(k as i32) }
                    })
                })
                .collect();
            let est = channel(&image, channel_index);
            if m == 1 {
                // Nearly exact pixel by pixel (only where in the pixel the
                // sixteen samples fall varies): a flipped, shifted or
                // lane-swapped image of the right mean fails here.
                let worst = est
                    .iter()
                    .zip(&expected)
                    .map(|(e, x)| (e - x).abs() / x)
                    .fold(0.0, f64::max);
                // Measured: 1.7e-3 at most at 16 spp (a simulation of the
                // scrambled net put the worst pixel of 20,000 images at
                // 3.8e-3); a flipped or shifted image is off by far more.
                assert!(
                    worst <= 1e-2,
                    "channel {channel_index}: a pixel is off by {worst:e} of its value"
                );
            }
            assert_unbiased(
                &format!(
                    "off-centre furnace -m {m} {bounces:?} roulette {roulette} channel {channel_index}"
                ),
                &est,
                &expected,
                1e-4,
            );
        }
    }
}

#[test]
fn zero_bounce_shows_only_emission() {
    let scene = furnace();
    let image = render(&scene, &settings(8, 6, 4, 0), 1);
    assert!(image.pixels.iter().all(|p| *p == Vec3::ZERO));
}

/// A diffuse floor (y = 0) seen from straight above.
fn floor_scene(b: &mut Builder) {
    let floor = b.material(Material::Diffuse {
        albedo: Vec3::splat(ALBEDO),
    });
    b.floor(50.0, floor);
}

/// Camera rays run from `znear` to `zfar` along their unit directions, as
/// the reference's do, so the far clipping surface is a sphere about the
/// eye: looking straight down from height 1 at a floor under a sky, with
/// zfar 1.3, the floor shows as a disc of radius √(1.3² − 1) ≈ 0.83
/// about the nadir (lit pixels read ρ·L exactly, sky light by light
/// sampling) and black outside it. (Clipped at the plane 1.3 below the
/// eye, the whole floor, 1 below, would show.) Pixels the circle crosses
/// are not checked.
#[test]
fn camera_rays_end_at_zfar_along_each_ray() {
    let mut b = Builder::default();
    floor_scene(&mut b);
    b.lights.push(Light::Hemisphere {
        radiance: Vec3::ONE,
    });
    let mut camera = top_down_camera(1.0);
    (camera.znear, camera.zfar) = (0.2, 1.3);
    let scene = b.build(camera);
    let (w, h) = (W, H);
    let image = render(&scene, &settings(w, h, 4, 1), 2);
    let camera = &scene.camera;
    let view = camera.view(w, h);
    // Distance from the eye to the floor point seen at film position (fx, fy).
    let distance = |fx: f32, fy: f32| {
        let d = camera.direction(&view, fx, fy).normalize();
        (1.0 / -d.y) as f64
    };
    let (nadir_x, nadir_y) = (w as f32 / 2.0, h as f32 / 2.0);
    let (mut lit, mut dark) = (0, 0);
    for row in 0..h {
        let y = (h - 1 - row) as f32;
        for x in 0..w {
            let x = x as f32;
            // The farthest point of the pixel is a corner; the nearest is
            // the nadir clamped into the pixel.
            let farthest = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(i, j)| distance(x + i, y + j))
                .into_iter()
                .fold(0.0, f64::max);
            let nearest = distance(nadir_x.clamp(x, x + 1.0), nadir_y.clamp(y, y + 1.0));
            let value = image.pixels[(row * w) as usize + x as usize];
            if farthest < 1.3 {
                lit += 1;
                assert!(
                    (value - Vec3::splat(ALBEDO)).abs().max_element() < 1e-5,
                    "pixel ({x}, {row}), at most {farthest} away: {value}"
                );
            } else if nearest > 1.3 {
                dark += 1;
                assert_eq!(value, Vec3::ZERO, "pixel ({x}, {row}), {nearest} away");
            }
        }
    }
    assert!(lit > 100 && dark > 300, "{lit} lit, {dark} dark pixels");
}

/// Looking straight down from `height` with a 90° vertical field of view
/// over a `W × H` image (below any light in these scenes).
fn top_down_camera(height: f32) -> wavepath::scene::Camera {
    camera(
        Vec3::new(0.0, height, 0.0),
        Vec3::NEG_Y,
        Vec3::NEG_Z,
        90.0,
        H,
    )
}

const W: u32 = 40;
const H: u32 = 30;

/// Where the centre ray of each pixel meets the floor (y = 0).
fn floor_points(scene: &Scene, w: u32, h: u32) -> Vec<Vec3> {
    let mut points = Vec::new();
    for row in 0..h {
        for x in 0..w {
            let d = pixel_ray(scene, w, h, x, row);
            let o = scene.camera.position;
            points.push(o + (-o.y / d.y) * d);
        }
    }
    points
}

#[test]
fn point_light_falls_off_with_the_inverse_square() {
    for height in [0.5f32, 1.0, 2.0, 4.0] {
        let mut b = Builder::default();
        floor_scene(&mut b);
        let intensity = 3.0;
        b.lights.push(Light::Point {
            position: Vec3::new(0.3, height, -0.2),
            intensity: Vec3::splat(intensity),
        });
        let scene = b.build(top_down_camera(3.0));
        let (w, h) = (W, H);
        let image = render(&scene, &settings(w, h, 1, 1), 2);
        for (p, x) in image.pixels.iter().zip(floor_points(&scene, w, h)) {
            let d = Vec3::new(0.3, height, -0.2) - x;
            // L = ρ/π · I cos θ / d², cos θ = height / d.
            let expected =
                ALBEDO as f64 / PI * intensity as f64 * height as f64 / (d.length() as f64).powi(3);
            assert!(
                ((p.x as f64) - expected).abs() <= 2e-4 * expected,
                "height {height}: at {x}: {} vs {expected}",
                p.x
            );
        }
    }
}

/// A square light of side 1 at height 1 facing down, as a rectangle light
/// or as an emissive two-triangle mesh, over the floor.
fn square_light_scene(as_mesh: bool, radiance: f32) -> (Scene, [Vec3; 4]) {
    let mut b = Builder::default();
    floor_scene(&mut b);
    let c = Vec3::new(0.2, 1.0, 0.1);
    let corners = [
        c + Vec3::new(-0.5, 0.0, -0.5),
        c + Vec3::new(0.5, 0.0, -0.5),
        c + Vec3::new(0.5, 0.0, 0.5),
        c + Vec3::new(-0.5, 0.0, 0.5),
    ];
    if as_mesh {
        let m = b.material(Material::Emission {
            radiance: Vec3::splat(radiance),
            one_sided: false,
        });
        b.quad(corners[0], corners[1], corners[2], corners[3], m);
    } else {
        b.lights.push(Light::Area {
            center: c,
            normal: Vec3::NEG_Y,
            dim_x: Vec3::X,
            dim_y: Vec3::Z,
            radiance: Vec3::splat(radiance),
        });
    }
    (b.build(top_down_camera(0.8)), corners)
}

fn square_light_expected(
    scene: &Scene,
    corners: &[Vec3; 4],
    radiance: f32,
    w: u32,
    h: u32,
) -> Vec<f64> {
    pixel_average(scene, w, h, |x| {
        ALBEDO as f64 / PI * radiance as f64 * polygon_irradiance(x, Vec3::Y, corners)
    })
}

#[test]
fn rectangle_light_matches_the_form_factor() {
    let (w, h) = (W, H);
    for as_mesh in [false, true] {
        let (scene, corners) = square_light_scene(as_mesh, 4.0);
        let expected = square_light_expected(&scene, &corners, 4.0, w, h);
        let mut s = settings(w, h, 16, 1);
        s.integrator.light_samples = 4;
        let est = channel(&render(&scene, &s, 2), 0);
        assert_unbiased(
            &format!("square light (mesh: {as_mesh}), light sampling"),
            &est,
            &expected,
            1e-5,
        );
    }
}

#[test]
fn hemisphere_sampling_light_sampling_and_one_bounce_agree() {
    let (w, h) = (W, H);
    let (scene, corners) = square_light_scene(false, 4.0);
    let expected = square_light_expected(&scene, &corners, 4.0, w, h);
    // Uniform hemisphere sampling of the same direct lighting (much noisier).
    let mut s = settings(w, h, 64, 1);
    s.integrator.hemisphere = true;
    s.integrator.light_samples = 4;
    let hemi = channel(&render(&scene, &s, 2), 0);
    assert_unbiased("square light, hemisphere sampling", &hemi, &expected, 1e-5);
    // Light sampling at -m 2, every bounce accumulated: light cannot
    // bounce twice here (floor only), so the same direct light as -m 1
    // (light sampling at -m 1: `rectangle_light_matches_the_form_factor`).
    let mut s = settings(w, h, 16, 2);
    s.integrator.light_samples = 4;
    let two = channel(&render(&scene, &s, 2), 0);
    assert_unbiased("square light, -m 2", &two, &expected, 1e-5);
    // -m 2, only the last bounce, in a scene where light cannot bounce twice
    // (floor only): zero, so direct lighting is all of -m 1.
    let mut s = settings(w, h, 4, 2);
    s.integrator.bounces = Bounces::Last;
    let second = channel(&render(&scene, &s, 2), 0);
    assert!(
        second.iter().all(|&v| v == 0.0),
        "a lone floor has no second bounce"
    );
}

/// Irradiance at floor point `x` (normal +y) from a sphere of radiance
/// `radiance` fully above the floor's horizon: E = π L (r/d)² cos θ, d
/// the distance to its centre.
fn sphere_irradiance(x: Vec3, center: Vec3, radius: f32, radiance: f32) -> f64 {
    let d = (center - x).as_dvec3();
    let dist = d.length();
    PI * radiance as f64 * (radius as f64 / dist).powi(2) * d.y / dist
}

#[test]
fn sphere_light_matches_the_closed_form() {
    // See `sphere_irradiance`.
    let (w, h) = (W, H);
    let (center, radius, radiance) = (Vec3::new(-0.3, 1.2, 0.2), 0.4f32, 3.0f32);
    let mut b = Builder::default();
    floor_scene(&mut b);
    let m = b.material(Material::Emission {
        radiance: Vec3::splat(radiance),
        one_sided: false,
    });
    b.sphere(center, radius, m);
    let scene = b.build(top_down_camera(0.8));
    let expected = pixel_average(&scene, w, h, |x| {
        ALBEDO as f64 / PI * sphere_irradiance(x, center, radius, radiance)
    });
    let mut s = settings(w, h, 16, 1);
    s.integrator.light_samples = 4;
    // Every pixel sees the floor: the camera's rays all point down from
    // y = 0.8, the sphere's lowest point.
    assert!(center.y - radius >= 0.8);
    let est = channel(&render(&scene, &s, 2), 0);
    assert_unbiased("sphere light", &est, &expected, 1e-5);
}

/// Each path's light samples are drawn for its own shading point: one
/// camera ray through each pixel's centre (eight neighbouring pixels share
/// a chunk of eight lanes) and 256 light samples, pixel by pixel against
/// the closed form at that point, for the lights sampled lane by lane
/// (spheres and emissive meshes). A lane that took another lane's point,
/// normal or draws would show a neighbour's light.
#[test]
fn light_samples_land_on_their_own_pixels() {
    let (w, h) = (W, H);
    let (center, radius, radiance) = (Vec3::new(-0.3, 1.2, 0.2), 0.4f32, 3.0f32);
    let tri = [
        Vec3::new(-0.9, 1.0, -0.6),
        Vec3::new(0.3, 1.0, -0.6),
        Vec3::new(-0.9, 1.0, 0.6),
    ];
    for sphere in [true, false] {
        let mut b = Builder::default();
        floor_scene(&mut b);
        let m = b.material(Material::Emission {
            radiance: Vec3::splat(radiance),
            one_sided: false,
        });
        if sphere {
            b.sphere(center, radius, m);
        } else {
            b.triangle(tri[0], tri[1], tri[2], m);
        }
        let scene = b.build(top_down_camera(0.8));
        let irradiance = |x: Vec3| {
            let e = if sphere {
                sphere_irradiance(x, center, radius, radiance)
            } else {
                radiance as f64 * polygon_irradiance(x, Vec3::Y, &tri)
            };
            ALBEDO as f64 / PI * e
        };
        let expected: Vec<f64> = floor_points(&scene, w, h)
            .into_iter()
            .map(irradiance)
            .collect();
        let mut s = settings(w, h, 1, 1);
        s.integrator.light_samples = 256;
        let est = channel(&render(&scene, &s, 2), 0);
        // (The camera, at 0.8, looks down: below both emitters.)
        let relative = |i: usize, j: usize| (est[i] - expected[j]).abs() / expected[j];
        let worst = (0..est.len()).map(|i| relative(i, i)).fold(0.0, f64::max);
        // Measured: 3.6e-4 (sphere) and 1.5e-3 (triangle) at most.
        assert!(
            worst <= 1e-2,
            "sphere {sphere}: a pixel is off by {worst:e}"
        );
        // The test's power: each row's light changes by more than that
        // from one pixel to the next somewhere, so an image whose lanes
        // took their neighbours' points would fail.
        let shifted = (0..est.len() - 1)
            .filter(|i| (i + 1) % w as usize != 0)
            .map(|i| relative(i, i + 1))
            .fold(0.0, f64::max);
        assert!(
            shifted > 3e-2,
            "sphere {sphere}: neighbours differ by {shifted:e}"
        );
    }
}

#[test]
fn adaptive_and_fixed_sampling_agree() {
    // The off-centre furnace: every pixel's value differs, and so does its
    // noise, so pixels stop at different counts.
    let (c, albedo) = (Vec3::new(0.6, 0.0, 0.0), Vec3::splat(ALBEDO));
    let scene = off_centre_furnace(c, albedo);
    let m = 3;
    let (w, h) = (24, 18);
    let rho = ALBEDO as f64;
    let expected: Vec<f64> = off_centre_first_bounce(&scene, c, w, h)
        .iter()
        .map(|&e1| rho * e1 + rho.powi(2) + rho.powi(3))
        .collect();
    let mut s = settings(w, h, 256, m);
    s.adaptive = Some(Adaptive {
        samples_per_batch: 16,
        tolerance: 0.05,
    });
    let adaptive = render(&scene, &s, 2);
    let stopped_at: std::collections::BTreeSet<u32> = adaptive.samples.iter().copied().collect();
    assert!(stopped_at.len() >= 3, "pixels stopped at {stopped_at:?}");
    assert!(
        stopped_at
            .iter()
            .all(|&n| (16..=256).contains(&n) && n % 16 == 0),
        "{stopped_at:?}"
    );
    // Stopping where a pixel's interval happens to be small is a bias of
    // its own, by far smaller than the tolerance: with right-skewed
    // samples a run of low ones looks converged sooner. Measured over
    // twelve seeds: −0.12% to −0.22% of the mean at 4.5–2.2σ, where fixed
    // 64-spp renders of the same seeds read |z| ≤ 1.4. The slack allows
    // 0.5% (a tenth of the tolerance); dividing by one sample too few,
    // +1/n on every pixel that stops early (+2.6% here), fails.
    let est = channel(&adaptive, 1);
    assert_unbiased("off-centre furnace, adaptive", &est, &expected, 5e-3);

    let scene = furnace();
    let expected = shown(Bounces::Accumulate, m, furnace_bounce);

    // Tests further apart than the renderer's largest pass (16 samples):
    // still every 96 samples exactly, the passes between them summed in.
    s.adaptive = Some(Adaptive {
        samples_per_batch: 96,
        tolerance: 0.05,
    });
    let adaptive = render(&scene, &s, 2);
    assert!(
        adaptive
            .samples
            .iter()
            .all(|&n| [96, 192, 256].contains(&n)),
        "{:?}",
        adaptive.samples
    );
    // The same 0.5% slack: one sample too few here (+1/96 on every
    // pixel, all of which stop at the first test) fails with room to
    // spare (it was within a tenth of the 1% slack this half had).
    let est = channel(&adaptive, 1);
    assert_unbiased("furnace, adaptive", &est, &vec![expected; est.len()], 5e-3);
}

/// Convergence tests further apart than the renderer's largest pass (16
/// samples) fall exactly every `samples_per_batch` samples, and a pixel
/// that never converges takes exactly `-s`, the last pass cut short. The
/// pixels stop at different counts here (the furnace's all stop at the
/// first test), and the image still matches the form factor: adaptive and
/// fixed sampling agree.
#[test]
fn adaptive_tests_span_passes() {
    let (scene, corners) = square_light_scene(false, 4.0);
    let mut s = settings(24, 18, 250, 1);
    s.adaptive = Some(Adaptive {
        samples_per_batch: 96,
        tolerance: 0.05,
    });
    let image = render(&scene, &s, 2);
    let count = |n: u32| image.samples.iter().filter(|&&k| k == n).count();
    assert_eq!(
        count(96) + count(192) + count(250),
        image.samples.len(),
        "{:?}",
        image.samples
    );
    assert!(count(96) > 0 && count(250) > 0, "{:?}", image.samples);
    let expected = square_light_expected(&scene, &corners, 4.0, 24, 18);
    // Stopping when the interval is small biases by far less than the
    // tolerance (measured: 1.4 standard errors, 1e-4 of the mean).
    assert_unbiased(
        "square light, adaptive",
        &channel(&image, 0),
        &expected,
        1e-3,
    );
}

/// Progress comes pass by pass, not tile by tile: each tile of a 16 × 16
/// image of 256 samples reports after each of its sixteen 16-sample
/// passes, so a small image of many samples does not sit at 0% until it
/// is done.
#[test]
fn progress_is_reported_after_every_pass() {
    let (scene, _) = square_light_scene(false, 4.0);
    let s = settings(16, 16, 256, 1);
    let (_, reports) = render_reporting(&scene, &s, 2);
    let tiles = wavepath::film::Tile::whole(16, 16).split_for(16, 2);
    assert_eq!(reports.len(), 16 * tiles.len(), "{reports:?}");
    assert_eq!(reports.iter().sum::<u64>(), 16 * 16 * 256);

    // Adaptive, on one thread (one tile): after the k-th test, a pixel
    // that has stopped counts all of -s as done, one still going its 16k
    // samples. So a converged pixel's rest is counted when it stops, not
    // at the end of its tile.
    let (c, albedo) = (Vec3::new(0.6, 0.0, 0.0), Vec3::splat(ALBEDO));
    let scene = off_centre_furnace(c, albedo);
    let mut s = settings(16, 16, 256, 2);
    s.adaptive = Some(Adaptive {
        samples_per_batch: 16,
        tolerance: 0.05,
    });
    let (image, reports) = render_reporting(&scene, &s, 1);
    assert_eq!(
        wavepath::film::Tile::whole(16, 16).split_for(16, 1).len(),
        1
    );
    assert!(!reports.is_empty());
    let mut done = 0;
    for (k, units) in reports.iter().enumerate() {
        done += units;
        let taken = 16 * (k as u32 + 1);
        let expected: u64 = image
            .samples
            .iter()
            .map(|&n| u64::from(if n <= taken { 256 } else { taken }))
            .sum();
        assert_eq!(done, expected, "after {taken} samples: {reports:?}");
    }
    let stops: std::collections::BTreeSet<u32> = image.samples.iter().copied().collect();
    assert!(stops.len() >= 3, "pixels stopped at {stops:?}");
}

/// Ctrl-C leaves an evenly sampled image, not finished tiles beside black
/// ones: tiles take their passes in turn, so a render stopped after 20 of
/// its 64 tile passes (16 tiles, four passes of 16 samples each) has every
/// pixel at one or two passes; and each pixel is, bit for bit, that pixel
/// of a whole render of as many samples (a sample depends only on its
/// index, and the film sums them in order).
#[test]
fn an_interrupted_render_has_every_pixel_sampled_evenly() {
    let (scene, _) = square_light_scene(false, 4.0);
    let s = settings(64, 64, 64, 2);
    assert_eq!(
        wavepath::film::Tile::whole(64, 64).split_for(16, 2).len(),
        16
    );
    let whole = [16, 32].map(|spp| render(&scene, &settings(64, 64, spp, 2), 1));
    for threads in [1, 2] {
        let (out, reports) = render_until(&scene, &s, threads, 20);
        assert!(!out.complete);
        // Passes in flight when the render is stopped are finished: at
        // most one per other thread.
        assert!(
            (20..20 + threads).contains(&reports.len()),
            "{threads} threads: {} passes",
            reports.len()
        );
        let counts: std::collections::BTreeSet<u32> = out.image.samples.iter().copied().collect();
        assert_eq!(counts, [16, 32].into(), "{threads} threads");
        for (i, (&n, p)) in out.image.samples.iter().zip(&out.image.pixels).enumerate() {
            let whole = &whole[n as usize / 16 - 1];
            assert_eq!(
                p.to_array().map(f32::to_bits),
                whole.pixels[i].to_array().map(f32::to_bits),
                "pixel {i} after {n} samples, {threads} threads"
            );
        }
    }
}

#[test]
fn images_are_bit_identical_across_threads_and_batch_sizes() {
    // A two-triangle floor (no tree to speak of) and a shipped mesh scene
    // (a real BVH: camera rays of a pixel go through packet traversal,
    // grouped differently by each batch size).
    let (floor, _) = square_light_scene(false, 4.0);
    let mut knot = wavepath::scene::collada::load_file(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/torus_knot.dae"
    )))
    .unwrap();
    // Under an environment map too, whose samples take random bits of
    // their own.
    let sky: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new(0.1 * i as f32, 0.3, 0.05))
        .collect();
    let sky = wavepath::scene::EnvironmentMap::new(4, 2, sky).unwrap();
    knot.lights
        .push(Light::Environment(std::sync::Arc::new(sky)));
    // Each setting also with what draws more random numbers or drops
    // pixels: roulette at every vertex from the second, the adaptive mask,
    // hemisphere probes, a thin lens.
    let base = {
        let mut s = settings(37, 23, 8, 4);
        s.integrator.light_samples = 2;
        s
    };
    let roulette_and_mask = {
        let mut s = base;
        s.spp = 16;
        s.integrator.max_depth = 6;
        s.integrator.roulette_depth = 1;
        s.adaptive = Some(Adaptive {
            samples_per_batch: 4,
            tolerance: 0.2,
        });
        s
    };
    let probes_and_lens = {
        let mut s = base;
        s.integrator.hemisphere = true;
        s.lens_radius = 0.05;
        s.focal_distance = 3.0;
        s
    };
    for scene in [floor, knot] {
        for mut s in [base, roulette_and_mask, probes_and_lens] {
            let one = render(&scene, &s, 1);
            s.batch_size = 61;
            s.tile_size = 7;
            let two = render(&scene, &s, 2);
            assert!(one.pixels.iter().any(|p| *p != Vec3::ZERO));
            if s.adaptive.is_some() {
                assert!(
                    one.samples.iter().any(|&n| n < s.spp),
                    "no pixel left the mask"
                );
            }
            assert_same_bits(&one, &two);
        }
    }
    // A small image, adaptive: one tile on one thread, cut into smaller
    // ones for two (`Tile::split_for`), the same bits.
    let (floor, _) = square_light_scene(false, 4.0);
    let mut small = roulette_and_mask;
    (small.width, small.height) = (12, 9);
    assert!(wavepath::film::Tile::whole(12, 9).split_for(16, 2).len() > 1);
    let one = render(&floor, &small, 1);
    assert!(one.pixels.iter().any(|p| *p != Vec3::ZERO));
    assert!(
        one.samples.iter().any(|&n| n < small.spp),
        "no pixel left the mask"
    );
    assert_same_bits(&one, &render(&floor, &small, 2));
}

/// Asserts two images hold the same sample counts and the same pixel bits.
fn assert_same_bits(one: &Image, two: &Image) {
    assert_eq!(one.samples, two.samples);
    for (a, b) in one.pixels.iter().zip(&two.pixels) {
        assert_eq!(
            a.to_array().map(f32::to_bits),
            b.to_array().map(f32::to_bits)
        );
    }
}

#[test]
fn sheared_rectangle_light_matches_the_form_factor() {
    // A node transform that shears the light makes it a parallelogram: its
    // area is |dim_x × dim_y|, not |dim_x|·|dim_y|.
    let (w, h) = (W, H);
    let mut b = Builder::default();
    floor_scene(&mut b);
    let light = Light::Area {
        center: Vec3::new(0.1, 1.0, 0.0),
        normal: Vec3::NEG_Y,
        dim_x: Vec3::new(1.0, 0.0, 0.0),
        dim_y: Vec3::new(0.6, 0.0, 0.8),
        radiance: Vec3::splat(4.0),
    };
    let corners = light.area_corners().unwrap();
    b.lights.push(light);
    let scene = b.build(top_down_camera(0.8));
    let expected = square_light_expected(&scene, &corners, 4.0, w, h);
    let mut s = settings(w, h, 16, 1);
    s.integrator.light_samples = 4;
    let est = channel(&render(&scene, &s, 2), 0);
    assert_unbiased("sheared rectangle light", &est, &expected, 1e-5);
    s.integrator.hemisphere = true;
    s.spp = 64;
    let hemi = channel(&render(&scene, &s, 2), 0);
    assert_unbiased(
        "sheared rectangle light, hemisphere sampling",
        &hemi,
        &expected,
        1e-5,
    );
}

/// Camera rays straight up from a floor point: every pixel sees the sky.
fn looking_up_camera() -> wavepath::scene::Camera {
    camera(Vec3::new(0.0, 0.5, 0.0), Vec3::Y, Vec3::Z, 60.0, H)
}

#[test]
fn sky_light_on_a_floor_reflects_albedo_times_its_radiance() {
    // A uniform sky of radiance L over the upper hemisphere gives a
    // horizontal floor E = π L, so L_o = ρ/π · π L = ρ L at every point;
    // a lone floor reflects nothing further at any depth.
    let radiance = 2.0f32;
    let sky_scene = |camera| {
        let mut b = Builder::default();
        floor_scene(&mut b);
        b.lights.push(Light::Hemisphere {
            radiance: Vec3::new(radiance, 0.5 * radiance, 0.0),
        });
        b.build(camera)
    };
    let scene = sky_scene(top_down_camera(3.0));
    let expected = (ALBEDO * radiance) as f64;
    for (hemisphere, depth) in [(false, 1), (false, 3), (true, 1)] {
        let mut s = settings(W, H, 16, depth);
        s.integrator.hemisphere = hemisphere;
        s.integrator.light_samples = 2;
        let image = render(&scene, &s, 2);
        let what = format!("sky, -H {hemisphere}, -m {depth}");
        for (c, scale) in [(0, 1.0), (1, 0.5)] {
            let est = channel(&image, c);
            assert_unbiased(&what, &est, &vec![scale * expected; est.len()], 1e-5);
        }
        assert!(
            image.pixels.iter().all(|p| p.z == 0.0),
            "{what}: blue light"
        );
    }
    // The sky lights surfaces but is not seen: camera rays that escape are black.
    let up = sky_scene(looking_up_camera());
    let image = render(&up, &settings(W, H, 4, 3), 2);
    assert!(image.pixels.iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn directional_light_lights_a_floor_by_its_cosine() {
    // Radiance E arriving from one direction at angle θ from the normal:
    // L_o = ρ/π · E cos θ, the same at every floor point.
    let to_light = Vec3::new(1.0, 2.0, 0.5).normalize();
    let radiance = 3.0f32;
    // The lit floor, with `more` lights besides the directional one.
    let lit_floor = |more: &[Light]| {
        let mut b = Builder::default();
        floor_scene(&mut b);
        b.lights.push(Light::Directional {
            to_light,
            radiance: Vec3::splat(radiance),
        });
        b.lights.extend_from_slice(more);
        b.build(top_down_camera(3.0))
    };
    let scene = lit_floor(&[]);
    let expected = ALBEDO as f64 / PI * radiance as f64 * to_light.y as f64;
    let image = render(&scene, &settings(W, H, 2, 2), 2);
    for p in &image.pixels {
        assert!(
            ((p.x as f64) - expected).abs() <= 1e-5 * expected,
            "{p} vs {expected}"
        );
    }
    // Uniform hemisphere probes never find a delta light (a direction or a
    // point), as in the reference: -H leaves such scenes black.
    let scene = lit_floor(&[Light::Point {
        position: Vec3::new(0.0, 1.0, 0.0),
        intensity: Vec3::splat(5.0),
    }]);
    let mut s = settings(W, H, 4, 1);
    s.integrator.hemisphere = true;
    let image = render(&scene, &s, 2);
    assert!(image.pixels.iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn emissive_triangles_of_unequal_area_and_radiance_match_their_form_factors() {
    // Two disjoint emissive triangles at height 1, areas 0.72 and 0.045,
    // with radiances that differ per channel: a triangle chosen with one
    // probability and weighted with another, or lit with another
    // triangle's radiance, shows as a biased channel.
    let big = [
        Vec3::new(-0.9, 1.0, -0.6),
        Vec3::new(0.3, 1.0, -0.6),
        Vec3::new(-0.9, 1.0, 0.6),
    ];
    let small = [
        Vec3::new(0.4, 1.0, 0.0),
        Vec3::new(0.7, 1.0, 0.0),
        Vec3::new(0.4, 1.0, 0.3),
    ];
    let (l_big, l_small) = (Vec3::new(2.0, 0.0, 1.0), Vec3::new(8.0, 0.0, 16.0));
    let mut b = Builder::default();
    floor_scene(&mut b);
    for (tri, radiance) in [(big, l_big), (small, l_small)] {
        let m = b.material(Material::Emission {
            radiance,
            one_sided: false,
        });
        b.triangle(tri[0], tri[1], tri[2], m);
    }
    let scene = b.build(top_down_camera(0.8));
    let mut s = settings(W, H, 16, 1);
    s.integrator.light_samples = 4;
    let image = render(&scene, &s, 2);
    for c in [0, 2] {
        let expected = pixel_average(&scene, W, H, |x| {
            ALBEDO as f64 / PI
                * (l_big[c] as f64 * polygon_irradiance(x, Vec3::Y, &big)
                    + l_small[c] as f64 * polygon_irradiance(x, Vec3::Y, &small))
        });
        assert_unbiased(
            &format!("two emissive triangles, channel {c}"),
            &channel(&image, c),
            &expected,
            1e-5,
        );
    }
}

/// An emissive sphere of radius r and radiance Lₑ at the centre of the
/// diffuse furnace sphere (radius 1, albedo ρ). By symmetry every wall
/// point sees the same: the emitter fills a cap of form factor s = r², so
/// bounce 1 brings ρ Lₑ s, and every further bounce multiplies by ρ(1 − s)
/// (the emitter reflects nothing and hides that part of the wall). BSDF
/// rays hit the emitter all the time here, so emission counted both by
/// them and by light sampling would show at once.
fn furnace_with_emitter(radius: f32, radiance: f32) -> Scene {
    let mut b = Builder::default();
    let wall = b.material(Material::Diffuse {
        albedo: Vec3::splat(ALBEDO),
    });
    let lamp = b.material(Material::Emission {
        radiance: Vec3::splat(radiance),
        one_sided: false,
    });
    b.sphere(Vec3::ZERO, 1.0, wall);
    b.sphere(Vec3::ZERO, radius, lamp);
    // Between the spheres, looking out at the wall.
    b.build(camera(
        Vec3::new(0.0, 0.0, 0.7),
        Vec3::new(0.2, -0.1, 1.0),
        Vec3::Y,
        60.0,
        18,
    ))
}

#[test]
fn furnace_lit_by_an_emitter_it_can_hit_matches_the_series() {
    let (r, le) = (0.4f64, 1.5f64);
    let scene = furnace_with_emitter(r as f32, le as f32);
    let s_cap = r * r;
    let rho = ALBEDO as f64;
    let bounce = |k: u32| rho * le * s_cap * (rho * (1.0 - s_cap)).powi(k as i32 - 1);
    // With -H too: the direct light of every vertex found by hemisphere
    // probes that hit the emitter, never also by the BSDF rays that do.
    for (m, bounces, from, hemisphere) in [
        (1, Bounces::Accumulate, 5, false),
        (4, Bounces::Accumulate, 5, false),
        (9, Bounces::Accumulate, 1, false),
        (4, Bounces::Last, 5, false),
        (4, Bounces::Indirect, 1, false),
        (1, Bounces::Accumulate, 5, true),
        (4, Bounces::Accumulate, 1, true),
    ] {
        let mut s = settings(24, 18, 32, m);
        s.integrator.bounces = bounces;
        s.integrator.roulette_depth = from;
        s.integrator.hemisphere = hemisphere;
        s.integrator.light_samples = if hemisphere { 4 } else { 1 };
        let expected = shown(bounces, m, bounce);
        let est = channel(&render(&scene, &s, 2), 1);
        assert_unbiased(
            &format!(
                "furnace with an emitter, -m {m} {bounces:?}, roulette from {from}, -H {hemisphere}"
            ),
            &est,
            &vec![expected; est.len()],
            1e-4,
        );
    }
}

/// Fraction of a unit disk left of the line x = u.
fn disk_fraction_left_of(u: f64) -> f64 {
    let u = u.clamp(-1.0, 1.0);
    0.5 + (u * (1.0 - u * u).sqrt() + u.asin()) / PI
}

#[test]
fn thin_lens_blurs_an_edge_by_its_circle_of_confusion() {
    // An emissive half-plane x < 0 at depth d, seen through a lens of
    // radius R focused at depth f. The ray through the film point whose
    // pinhole direction is (s, t, −1) leaves the lens point (l_x, l_y, 0)
    // toward f·(s, t, −1) and meets depth d at x = l_x (1 − d/f) + d s, so
    // the pixel sees the emitter for the part of the lens with
    // l_x (1 − d/f) < −d s: a disk of radius k = R |1 − d/f| cut by a line.
    // In focus (f = d) the edge is as sharp as through a pinhole.
    let (d, radius) = (2.0f32, 0.5f32);
    let mut b = Builder::default();
    let lamp = b.material(Material::Emission {
        radiance: Vec3::ONE,
        one_sided: false,
    });
    b.quad(
        Vec3::new(-20.0, -20.0, -d),
        Vec3::new(0.0, -20.0, -d),
        Vec3::new(0.0, 20.0, -d),
        Vec3::new(-20.0, 20.0, -d),
        lamp,
    );
    let scene = b.build(camera(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 40.0, H));
    let view = scene.camera.view(W, H);
    // Mean over the pixel's width of the lens fraction that sees the
    // emitter, through a lens of radius `radius`.
    let expected_column = |x: u32, f: f32, radius: f32| {
        const N: u32 = 256;
        let k = (radius * (1.0 - d / f).abs()) as f64;
        (0..N)
            .map(|i| {
                let dir =
                    scene
                        .camera
                        .direction(&view, x as f32 + (i as f32 + 0.5) / N as f32, 0.5);
                let s = (dir.x / -dir.z) as f64;
                let t = -(d as f64) * s;
                if k == 0.0 {
                    f64::from(t > 0.0)
                } else {
                    disk_fraction_left_of(t / k)
                }
            })
            .sum::<f64>()
            / N as f64
    };
    for f in [d, 2.0 * d, 0.5 * d] {
        let mut s = settings(W, H, 256, 0);
        s.lens_radius = radius;
        s.focal_distance = f;
        let image = render(&scene, &s, 2);
        let expected: Vec<f64> = (0..W).map(|x| expected_column(x, f, radius)).collect();
        if f != d {
            // The blur spans several columns; in focus only the edge's own.
            let partial = (0..W)
                .filter(|&x| (0.01..0.99).contains(&expected[x as usize]))
                .count();
            assert!(
                partial >= 6,
                "focus {f}: the edge spreads over {partial} columns"
            );
        }
        // Column by column (the blur's width, not just the image mean,
        // which any symmetric blur keeps). Every sample sees the emitter
        // or not, so a column's n = H·spp samples have a standard error of
        // at most √(e(1 − e)/n) about their expected fraction e (less, as
        // the samples are stratified). Taken from e rather than from the
        // samples, it does not shrink where a column's few misses happen
        // not to show. z = 5 over 40 columns: a false failure in fewer
        // than one in 40,000 runs.
        let red = channel(&image, 0);
        let samples = (H * s.spp) as f64;
        let se = |want: f64| (want * (1.0 - want) / samples).sqrt();
        let means: Vec<f64> = (0..W as usize)
            .map(|x| {
                (0..H as usize)
                    .map(|row| red[row * W as usize + x])
                    .sum::<f64>()
                    / H as f64
            })
            .collect();
        for (x, (&mean, &want)) in means.iter().zip(&expected).enumerate() {
            assert!(
                (mean - want).abs() <= 5.0 * se(want) + 1e-4,
                "focus {f}, column {x}: {mean:.4}, expected {want:.4} ± {:.1e}",
                se(want)
            );
        }
        if f == d {
            continue;
        }
        // Pooled over the columns: a blur too wide pulls every column
        // toward ½ and one too narrow pushes it away, so the signed sum
        // Σ (mean − e)·sgn(e − ½) over the columns (independent pixels)
        // moves with the lens radius: z = 5 again. It sees a lens 5%
        // narrower, which the columns alone let through at this spp.
        let signed_sum = |values: &[f64]| -> f64 {
            values
                .iter()
                .zip(&expected)
                .map(|(&v, &e)| (v - e) * (e - 0.5).signum())
                .sum()
        };
        let sigma = expected.iter().map(|&e| se(e).powi(2)).sum::<f64>().sqrt();
        let z = signed_sum(&means) / sigma;
        assert!(z.abs() <= 5.0, "focus {f}: blur width off, z = {z:.2}");
        // The test's power, from the closed forms alone: a lens 5% wider or
        // narrower moves the expected sum by 7σ or more.
        for scale in [1.05, 0.95] {
            let other: Vec<f64> = (0..W)
                .map(|x| expected_column(x, f, radius * scale))
                .collect();
            let shift = signed_sum(&other) / sigma;
            assert!(
                shift.abs() >= 7.0,
                "focus {f}: a lens of {scale}× the radius moves z by {shift:.2}"
            );
        }
    }
}

#[test]
fn normals_view_shows_the_normal_facing_the_viewer_as_colour() {
    // (n + 1) / 2 of the shading normal: the floor (n = +y) from above,
    // and the inside of the furnace sphere, whose normal at the point a
    // ray from the centre meets is −d, facing the camera at the centre.
    let mut b = Builder::default();
    floor_scene(&mut b);
    let floor = b.build(top_down_camera(3.0));
    let mut s = settings(W, H, 2, 3);
    s.integrator.view = View::Normals;
    let image = render(&floor, &s, 2);
    for p in &image.pixels {
        assert!(
            (*p - Vec3::new(0.5, 1.0, 0.5)).abs().max_element() < 1e-6,
            "{p}"
        );
    }
    // One sample per pixel: the ray through the pixel's centre.
    let sphere = furnace();
    let (w, h) = (W, H);
    let image = render(&sphere, &RenderSettings { spp: 1, ..s }, 2);
    for row in 0..h {
        for x in 0..w {
            let d = pixel_ray(&sphere, w, h, x, row).normalize();
            let want = 0.5 * (-d + Vec3::ONE);
            let got = image.pixels[(row * w + x) as usize];
            assert!(
                (got - want).abs().max_element() < 1e-4,
                "({x}, {row}): {got} vs {want}"
            );
        }
    }
    // Unless the settings say otherwise (converge's renders estimate each
    // pixel's average): then the one sample is a random point of the
    // pixel, another for each seed. Half a pixel turns the normal by up
    // to ~0.02 here.
    let jittered = |seed| {
        let one = RenderSettings {
            spp: 1,
            centre_single_sample: false,
            seed,
            ..s
        };
        render(&sphere, &one, 2)
    };
    let (a, b) = (jittered(1), jittered(2));
    let moved = |image: &Image, k: usize| {
        let (x, row) = (k as u32 % w, k as u32 / w);
        let d = pixel_ray(&sphere, w, h, x, row).normalize();
        (image.pixels[k] - 0.5 * (-d + Vec3::ONE))
            .abs()
            .max_element()
            > 1e-4
    };
    let n = (w * h) as usize;
    let off_centre = (0..n).filter(|&k| moved(&a, k)).count();
    let reseeded = (0..n).filter(|&k| a.pixels[k] != b.pixels[k]).count();
    assert!(off_centre > n * 9 / 10, "{off_centre} of {n} off centre");
    assert!(
        reseeded > n * 9 / 10,
        "{reseeded} of {n} changed by the seed"
    );
}

#[test]
fn area_light_shows_its_radiance_to_the_side_it_faces_and_nothing_behind() {
    // The square light of the form-factor tests (height 1, facing down).
    // From below, a camera ray that meets it sees exactly its radiance
    // (not the reference's spectrum/area·cos); from above it is black and
    // lights nothing: a floor above it, facing it, stays dark.
    let radiance = 4.0f32;
    let light = Light::Area {
        center: Vec3::new(0.0, 1.0, 0.0),
        normal: Vec3::NEG_Y,
        dim_x: Vec3::X,
        dim_y: Vec3::Z,
        radiance: Vec3::splat(radiance),
    };
    // The light alone, seen from `eye` looking along `forward`.
    let light_only = |eye: Vec3, forward: Vec3| {
        let b = Builder {
            lights: vec![light.clone()],
            ..Builder::default()
        };
        b.build(camera(eye, forward, Vec3::Z, 40.0, H))
    };
    let below = light_only(Vec3::ZERO, Vec3::Y);
    let image = render(&below, &settings(W, H, 4, 2), 2);
    let mut seen = 0;
    for row in 0..H {
        for x in 0..W {
            // Pixels whose whole footprint lies well inside the square.
            let d = pixel_ray(&below, W, H, x, row);
            let hit = d * (1.0 / d.y);
            if hit.x.abs().max(hit.z.abs()) < 0.4 {
                seen += 1;
                assert_eq!(image.pixels[(row * W + x) as usize], Vec3::splat(radiance));
            }
        }
    }
    assert!(seen > 20, "{seen} pixels on the light");

    // From above, camera rays meet the light's back: black, as is
    // everything else in a scene that holds only the light.
    let behind = light_only(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y);
    let image = render(&behind, &settings(W, H, 4, 2), 2);
    assert!(
        image.pixels.iter().all(|p| *p == Vec3::ZERO),
        "the light's back shows light to camera rays"
    );

    // A ceiling at height 2 facing down at the light's back, seen from
    // between them: black at any depth, by light sampling and by -H.
    let mut b = Builder::default();
    let grey = b.material(Material::Diffuse {
        albedo: Vec3::splat(ALBEDO),
    });
    let s = 50.0;
    b.quad(
        Vec3::new(-s, 2.0, -s),
        Vec3::new(s, 2.0, -s),
        Vec3::new(s, 2.0, s),
        Vec3::new(-s, 2.0, s),
        grey,
    );
    b.lights.push(light);
    let above = b.build(camera(Vec3::new(0.0, 1.5, 0.0), Vec3::Y, Vec3::Z, 90.0, H));
    for hemisphere in [false, true] {
        let mut st = settings(W, H, 8, 3);
        st.integrator.hemisphere = hemisphere;
        let image = render(&above, &st, 2);
        assert!(
            image.pixels.iter().all(|p| *p == Vec3::ZERO),
            "-H {hemisphere}: light reached the back side"
        );
    }
}
