//! Environment maps (`-e`): the sampler draws each cell of the map as often
//! as the probability it divides by, its estimates integrate the map's
//! light exactly (bilinear bleed included), and renders lit by a map match
//! closed forms and quadrature of the map.

mod common;

use std::f64::consts::PI;
use std::sync::Arc;

use common::render::*;
use glam::Vec3;
use wavepath::integrator::Settings;
use wavepath::integrator::environment::EnvironmentLight;
use wavepath::scene::environment::{azimuth, direction, polar_cosine};
use wavepath::scene::{EnvironmentMap, Light, Material, Scene};
use wavepath::wavefront::RenderSettings;

/// A small test map: mostly black (so light bleeds into black cells only
/// through the bilinear lookup), a dim blue band, one bright reddish
/// texel above the horizon and one below it.
fn test_map() -> EnvironmentMap {
    let (w, h) = (12u32, 6u32);
    let mut texels = vec![Vec3::ZERO; (w * h) as usize];
    for x in 0..w {
        texels[(w + x) as usize] = Vec3::new(0.0, 0.05, 0.2 + 0.02 * x as f32);
    }
    texels[(2 * w + 7) as usize] = Vec3::new(40.0, 12.0, 3.0);
    texels[(4 * w + 2) as usize] = Vec3::new(1.0, 6.0, 0.5);
    EnvironmentMap::new(w, h, texels).unwrap()
}

/// ∫ L(ω) g(ω) dΩ per channel, by the midpoint rule on a 64×64 grid in
/// every texel, in (φ, θ) with dΩ = sin θ dθ dφ.
fn integrate(map: &EnvironmentMap, g: impl Fn(Vec3) -> f64) -> [f64; 3] {
    const K: u32 = 64;
    let (w, h) = (map.width(), map.height());
    let cell = (2.0 * PI / w as f64) * (PI / h as f64) / (K * K) as f64;
    let mut sum = [0.0; 3];
    for sy in 0..h * K {
        let y = (sy as f64 + 0.5) / K as f64;
        let cos_theta = polar_cosine(y, h);
        let sin_theta = (1.0 - cos_theta * cos_theta).sqrt();
        for sx in 0..w * K {
            let x = (sx as f64 + 0.5) / K as f64;
            let d = direction(cos_theta, azimuth(x, w));
            let weight = g(d) * sin_theta * cell;
            let l = map.at(x, y);
            for c in 0..3 {
                sum[c] += f64::from(l[c]) * weight;
            }
        }
    }
    sum
}

/// Uniform draws as the renderer makes them: 24-bit fractions, and 32
/// random bits, from a counter hash.
fn draws(i: u32) -> (f32, f32, u32) {
    let h = |k: u32| wavepath::sampling::rng::hash_words(&[i, k]);
    let unit = |b: u32| (b >> 8) as f32 / 16_777_216.0;
    (unit(h(0)), unit(h(1)), h(2))
}

/// Every cell is drawn as often as its probability says (within 5σ of a
/// binomial count, over 2²⁰ draws), a cell the map lights at any point has
/// a probability above 0, and a cell that no texel near it lights has
/// none; `pdf` gives the density each sample was drawn with.
#[test]
fn cells_are_drawn_as_often_as_their_probability() {
    let map = test_map();
    let light = EnvironmentLight::new(Arc::new(map.clone())).unwrap();
    let (w, h) = (map.width() as usize, map.height() as usize);
    let n = 1u32 << 20;
    let mut counts = vec![0u64; w * h];
    let mut density = vec![0.0f64; w * h];
    for k in 0..n {
        let (u, v, bits) = draws(k);
        let s = light.sample(u, v, bits);
        let d = s.direction;
        assert!((d.length() - 1.0).abs() < 1e-5, "{d}");
        let (x, y) = map.position(d);
        let cell = (y as usize).min(h - 1) * w + (x as usize) % w;
        counts[cell] += 1;
        // The density and radiance it comes with are those of its
        // direction (the radiance to the rounding of an f32 direction:
        // ~1e-7 of a texel, where the radiance changes by up to 40 per
        // texel).
        let p = light.pdf(d);
        density[cell] = p;
        assert!(
            (s.pdf - p).abs() <= 1e-9 * p,
            "draw {k}: pdf {} against {p}",
            s.pdf
        );
        let radiance = map.radiance(d);
        assert!(
            (s.radiance - radiance).abs().max_element() <= 1e-4 * radiance.max_element() + 1e-4,
            "draw {k}: radiance {}, the map's {radiance}",
            s.radiance
        );
    }
    for j in 0..h {
        let band = polar_cosine(j as f64, h as u32) - polar_cosine(j as f64 + 1.0, h as u32);
        let solid_angle = 2.0 * PI / w as f64 * band;
        for i in 0..w {
            let cell = j * w + i;
            // The probability from the density at the cell's centre.
            let centre = direction(
                polar_cosine(j as f64 + 0.5, h as u32),
                azimuth(i as f64 + 0.5, w as u32),
            );
            let p = light.pdf(centre) * solid_angle;
            let lit_nearby = (-1..=1).any(|dy| {
                (-1..=1).any(|dx| map.texel(i as i64 + dx, j as i64 + dy).max_element() > 0.0)
            });
            assert_eq!(p > 0.0, lit_nearby, "cell ({i}, {j}): probability {p}");
            let expected = p * n as f64;
            let sigma = (expected * (1.0 - p)).sqrt();
            assert!(
                (counts[cell] as f64 - expected).abs() <= 5.0 * sigma + 1.0,
                "cell ({i}, {j}): drawn {} times, expected {expected:.1} ± {sigma:.1}",
                counts[cell]
            );
            if counts[cell] > 0 {
                assert!(
                    (density[cell] * solid_angle - p).abs() <= 1e-9,
                    "cell ({i}, {j})"
                );
            }
        }
    }
}

/// The light a surface of normal n receives, E = ∫ L(ω) max(0, n·ω) dΩ,
/// estimated from the sampler's weights, matches the map's integral by
/// quadrature per channel (z-test at 4.5σ over 2²⁰ draws). Most of the
/// map is black and lit only by bleed from its few bright texels: weights
/// built from the texels alone would leave out ~40% of that light.
#[test]
fn samples_integrate_the_map_exactly() {
    let map = test_map();
    let light = EnvironmentLight::new(Arc::new(map.clone())).unwrap();
    let n = 1u32 << 20;
    for normal in [
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::X,
        Vec3::new(0.3, -0.4, 0.87).normalize(),
    ] {
        let cos = |d: Vec3| f64::from(normal.dot(d)).max(0.0);
        let exact = integrate(&map, cos);
        let mut estimates: [Vec<f64>; 3] = Default::default();
        for k in 0..n {
            let (u, v, bits) = draws(k);
            let s = light.sample(u, v, bits);
            for (c, e) in estimates.iter_mut().enumerate() {
                e.push(f64::from(s.radiance[c]) / s.pdf * cos(s.direction));
            }
        }
        for c in 0..3 {
            let what = format!("normal {normal}, channel {c}");
            assert_unbiased(&what, &estimates[c], &vec![exact[c]; n as usize], 1e-4);
        }
    }
}

const ALBEDO: f32 = 0.5;

fn settings(spp: u32, max_depth: u32, hemisphere: bool) -> RenderSettings {
    RenderSettings {
        width: 40,
        height: 30,
        spp,
        seed: 11,
        integrator: Settings {
            max_depth,
            hemisphere,
            light_samples: 2,
            ..Settings::default()
        },
        ..RenderSettings::default()
    }
}

/// A diffuse sphere in a uniform environment of radiance L: convex, it sees
/// the map over each point's whole hemisphere, so it reflects exactly ρL at
/// any depth, by light sampling or by hemisphere probes; every camera ray
/// that misses it sees L itself. Where a continuation ray follows (`-m`
/// above 1), the map's light is shared between the map's samples and that
/// ray by multiple importance: still ρL, with under 0.6 of the standard
/// error of the map's samples alone (`-m 1`; the cosine-weighted ray is
/// the better strategy under an even sky, where half the map's samples
/// fall below the surface).
#[test]
fn a_sphere_in_a_uniform_environment_reflects_albedo_times_its_radiance() {
    let radiance = Vec3::new(2.0, 1.0, 0.25);
    let mut b = Builder::default();
    let grey = b.material(Material::Diffuse {
        albedo: Vec3::splat(ALBEDO),
    });
    b.sphere(Vec3::ZERO, 1.0, grey);
    let map = EnvironmentMap::uniform(radiance).unwrap();
    b.lights.push(Light::Environment(Arc::new(map)));
    let scene = b.build(camera(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::NEG_Z,
        Vec3::Y,
        40.0,
        30,
    ));
    let mut errors = Vec::new();
    for (max_depth, hemisphere) in [(1, false), (3, false), (1, true), (0, false)] {
        let image = render(&scene, &settings(16, max_depth, hemisphere), 2);
        let what = format!("uniform map, -m {max_depth}, -H {hemisphere}");
        let (mut sphere, mut background) = (Vec::new(), 0);
        for (k, p) in image.pixels.iter().enumerate() {
            let (x, row) = (k as u32 % 40, k as u32 / 40);
            // How near the pixel's centre ray passes the sphere's centre; a
            // pixel spans ~0.1 there, so 0.15 either side of the rim keeps
            // pixels that are wholly on or wholly off the sphere.
            let d = pixel_ray(&scene, 40, 30, x, row).normalize();
            let o = scene.camera.position;
            let passes = (o - o.dot(d) * d).length();
            if passes > 1.15 {
                background += 1;
                assert_eq!(*p, radiance, "{what}: background pixel ({x}, {row})");
            } else if passes < 0.85 {
                sphere.push(*p);
            }
        }
        assert!(background > 300 && sphere.len() > 50, "{what}");
        for c in 0..3 {
            let est: Vec<f64> = sphere.iter().map(|p| f64::from(p[c])).collect();
            let expected = if max_depth == 0 {
                0.0
            } else {
                f64::from(ALBEDO * radiance[c])
            };
            if max_depth == 0 {
                assert!(
                    est.iter().all(|&e| e == 0.0),
                    "{what}: zero bounce lit the sphere"
                );
            } else {
                assert_unbiased(&what, &est, &vec![expected; est.len()], 1e-5);
            }
            if c == 0 {
                errors.push(mean_and_standard_error(&est).1);
            }
        }
    }
    assert!(errors[1] < 0.6 * errors[0], "standard errors {errors:?}");
}

/// A diffuse floor under a map of small bright texels: every point sees
/// the upper half of the map, so it reflects ρ/π · ∫ L(ω) cos θ dΩ over
/// the upper hemisphere (by quadrature of the map), by light sampling, by
/// hemisphere probes and with further bounces alike (whose rays escape:
/// they share the map's light with its samples, and leave it to the
/// probes under `-H`).
#[test]
fn a_floor_reflects_the_light_of_the_upper_half_of_the_map() {
    let map = test_map();
    let exact = integrate(&map, |d| f64::from(d.y).max(0.0));
    let mut b = Builder::default();
    let floor = b.material(Material::Diffuse {
        albedo: Vec3::splat(ALBEDO),
    });
    b.floor(50.0, floor);
    b.lights.push(Light::Environment(Arc::new(map)));
    let scene: Scene = b.build(camera(
        Vec3::new(0.0, 3.0, 0.0),
        Vec3::NEG_Y,
        Vec3::NEG_Z,
        90.0,
        30,
    ));
    for (max_depth, hemisphere, spp) in
        [(1, false, 16), (2, false, 16), (1, true, 64), (2, true, 64)]
    {
        let image = render(&scene, &settings(spp, max_depth, hemisphere), 2);
        let what = format!("floor, -m {max_depth}, -H {hemisphere}");
        for (c, integral) in exact.iter().enumerate() {
            let expected = f64::from(ALBEDO) / PI * integral;
            let est = channel(&image, c);
            assert_unbiased(&what, &est, &vec![expected; est.len()], 1e-4);
        }
        assert_eq!(image.non_finite_count(), 0, "{what}");
    }
}

/// A diffuse sphere of radius r hanging at height c over a diffuse floor,
/// under a uniform map of radiance L: the sphere hides from a floor point
/// at distance d from its centre a cap of half-angle asin(r/d), wholly
/// above the horizon (c > r), centred at angle β from the normal with
/// cos β = c/d. A cap's projected solid angle is π sin²α cos β, so with
/// one bounce the floor reflects ρL(1 − r²c/d³): shadow rays toward the
/// map (light sampling) and probes (`-H`) must both stop at the sphere.
#[test]
fn a_sphere_shades_the_floor_under_a_uniform_environment_by_its_projected_solid_angle() {
    let radiance = Vec3::new(2.0, 1.0, 0.25);
    let (centre, r) = (Vec3::new(0.0, 1.25, 0.0), 1.0f32);
    let mut b = Builder::default();
    let grey = b.material(Material::Diffuse {
        albedo: Vec3::splat(ALBEDO),
    });
    b.floor(50.0, grey);
    b.sphere(centre, r, grey);
    b.lights.push(Light::Environment(Arc::new(
        EnvironmentMap::uniform(radiance).unwrap(),
    )));
    let (w, h) = (40, 30);
    // Looking down at the floor in front of the sphere, where its shade is
    // deepest (1 − r²/c² = 0.36 of the open floor under its centre).
    let eye = Vec3::new(0.0, 3.0, 6.0);
    let scene = b.build(camera(eye, -eye, Vec3::Y, 40.0, h));
    // Pixels none of whose rays come within 0.1 of the sphere see only the
    // floor (all rays here point down, the highest 6.6° below the horizon,
    // and meet the floor within the quad).
    let near_sphere = pixel_mean(&scene, w, h, |d| {
        let d = d.normalize();
        let to_centre = centre - eye;
        let passes = (to_centre - to_centre.dot(d) * d).length();
        assert!(d.y < -0.1, "a camera ray {d} misses the floor");
        f64::from(u8::from(passes < r + 0.1))
    });
    let shade = pixel_average(&scene, w, h, |x| {
        let d = f64::from((x - centre).length());
        1.0 - f64::from(r * r * centre.y) / (d * d * d)
    });
    let floor: Vec<usize> = (0..near_sphere.len())
        .filter(|&k| near_sphere[k] == 0.0)
        .collect();
    assert!(floor.len() > 800, "{} floor pixels", floor.len());
    let deepest = floor
        .iter()
        .map(|&k| shade[k])
        .fold(f64::INFINITY, f64::min);
    // The renders must tell the shade from open floor: the deepest seen is
    // well below 1, and so is the mean, which a render ignoring the sphere
    // (ρL everywhere) misses by far more than the tolerance.
    let mean_shade = floor.iter().map(|&k| shade[k]).sum::<f64>() / floor.len() as f64;
    assert!(
        deepest < 0.7 && mean_shade < 0.95,
        "the floor seen is barely shaded (deepest {deepest}, mean {mean_shade})"
    );
    for (hemisphere, spp) in [(false, 16), (true, 64)] {
        let image = render(&scene, &settings(spp, 1, hemisphere), 2);
        for c in 0..3 {
            let what = format!("sphere over floor, -H {hemisphere}, channel {c}");
            let open = f64::from(ALBEDO * radiance[c]);
            let est: Vec<f64> = floor
                .iter()
                .map(|&k| f64::from(image.pixels[k][c]))
                .collect();
            let expected: Vec<f64> = floor.iter().map(|&k| open * shade[k]).collect();
            assert_unbiased(&what, &est, &expected, 1e-4);
        }
    }
}
