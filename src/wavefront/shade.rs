//! Stage 3: shading. For every path that hit something: add emission,
//! draw light samples into shadow rays, sample the BSDF for the next ray,
//! and decide by Russian roulette whether the path goes on.
//!
//! Bounce accounting follows the reference: light found at path vertex `d`
//! (0 = the camera ray's hit) by emission has bounced `d` times; light
//! brought by next-event estimation at vertex `d` has bounced `d + 1` times.

use glam::Vec3;

use crate::integrator::bsdf::Surface;
use crate::integrator::lights::LightSet;
use crate::integrator::{Settings, View};
use crate::ray::{Hits, offset_by};
use crate::sampling::rng::VertexDraws;
use crate::sampling::warp;
use crate::scene::Geometry;

use super::paths::{Paths, ShadowRays};
use super::surface::SurfacePoints;

/// Buffers the shade stage reuses from wave to wave.
#[derive(Clone, Debug, Default)]
pub struct ShadeScratch {
    draws: VertexDraws,
    surfaces: SurfacePoints,
}

/// What the shade stage reads besides the paths.
pub struct ShadeInputs<'a> {
    pub geometry: &'a Geometry,
    pub surfaces: &'a [Surface],
    pub lights: &'a LightSet,
    pub settings: &'a Settings,
}

/// The blocks of two-dimensional draws every path vertex takes, in
/// order: [`BSDF_BLOCK`] for the next direction, then one block of `-l`
/// points per area-like light (delta lights need none) — or, with `-H`,
/// one block for all hemisphere probes. A fixed layout lets the whole
/// wave's draws be made up front, eight paths at a time, and gives every
/// vertex depth the same dimension pairs in every sample of a pixel, so
/// each draw is stratified across the pixel's samples.
fn vertex_blocks<'a>(inputs: &ShadeInputs<'a>) -> impl Iterator<Item = u32> + 'a {
    let settings = inputs.settings;
    let sources = &inputs.lights.sources;
    let probes = settings
        .hemisphere
        .then(|| sources.len().max(1) as u32 * settings.light_samples);
    let lights = sources
        .iter()
        .filter(move |light| !settings.hemisphere && !light.is_delta())
        .map(move |_| settings.light_samples);
    std::iter::once(1).chain(probes).chain(lights)
}

/// Block of [`vertex_blocks`] that samples the BSDF.
const BSDF_BLOCK: usize = 0;
/// First block of light (or hemisphere-probe) samples.
const FIRST_LIGHT_BLOCK: usize = 1;

/// Shades every path of the wave. Paths that missed or ended are marked
/// not alive; live ones get their next ray.
pub fn shade(
    inputs: &ShadeInputs,
    hits: &Hits,
    paths: &mut Paths,
    scratch: &mut ShadeScratch,
    shadow: &mut ShadowRays,
    probes: &mut ShadowRays,
) {
    let settings = inputs.settings;
    let ShadeScratch { draws, surfaces } = scratch;
    surfaces.compute(inputs.geometry, hits, &paths.rays);
    if settings.view == View::Path {
        draws.draw(&mut paths.stream, vertex_blocks(inputs));
    }
    for i in 0..paths.len() {
        let dir = paths.rays.direction(i);
        if !hits.is_hit(i) {
            on_miss(inputs, paths, i, dir);
            paths.alive[i] = false;
            continue;
        }
        let sp = surfaces.get(i);

        match settings.view {
            View::Normals => {
                // The normal facing the viewer: outward on closed meshes, and
                // into the room for the Cornell boxes' walls, as the
                // reference shows them.
                paths.radiance[i] = 0.5 * (sp.ns + Vec3::ONE);
                paths.alive[i] = false;
                continue;
            }
            View::BvhCost => {
                paths.alive[i] = false;
                continue;
            }
            View::Path => {}
        }

        let depth = paths.depth[i];
        let surface = inputs.surfaces[inputs.geometry.material(hits.prim[i]) as usize];
        match surface {
            Surface::Emitter {
                radiance,
                one_sided,
            } => {
                let seen = !one_sided || sp.front;
                if seen && (depth == 0 || paths.specular[i]) && settings.counts_bounce(depth) {
                    paths.radiance[i] += paths.throughput[i] * radiance;
                }
                paths.alive[i] = false;
            }
            Surface::Diffuse { albedo } => {
                let f = surface.f();
                let p_out = offset_by(sp.p, sp.ng, sp.err);
                if depth < settings.max_depth && settings.counts_bounce(depth + 1) {
                    let beta = paths.throughput[i] * f;
                    if settings.hemisphere {
                        direct_hemisphere(inputs, draws, i, p_out, sp.ns, beta, probes);
                    } else {
                        direct_lights(inputs, paths, draws, i, (sp.p, p_out, sp.ns), beta, shadow);
                    }
                }
                paths.alive[i] = depth + 1 < settings.max_depth
                    && continue_path(settings, paths, draws, i, p_out, sp.ns, albedo);
            }
        }
    }
}

/// A ray that left the scene: only the sky (hemisphere lights) can be seen,
/// and only by rays that were not camera rays.
fn on_miss(inputs: &ShadeInputs, paths: &mut Paths, i: usize, dir: Vec3) {
    let depth = paths.depth[i];
    let settings = inputs.settings;
    if settings.view == View::Path
        && paths.specular[i]
        && depth > 0
        && dir.y > 0.0
        && settings.counts_bounce(depth)
    {
        paths.radiance[i] += paths.throughput[i] * inputs.lights.sky;
    }
}

/// Next-event estimation: `-l` samples per area-like light, one per delta
/// light. Distances and angles are measured from the surface point `p`;
/// only the shadow rays start from the offset point `p_out`, so the offset
/// (large where the error bound is: 1 on a 2e6-wide ground plane) cannot
/// bias the lighting.
fn direct_lights(
    inputs: &ShadeInputs,
    paths: &mut Paths,
    draws: &VertexDraws,
    i: usize,
    (p, p_out, n): (Vec3, Vec3, Vec3),
    beta: Vec3,
    shadow: &mut ShadowRays,
) {
    let mut block = FIRST_LIGHT_BLOCK;
    for light in &inputs.lights.sources {
        // The `-l` samples of one light come from one stratified block.
        let (count, this_block) = if light.is_delta() {
            (1, None)
        } else {
            block += 1;
            (inputs.settings.light_samples, Some(block - 1))
        };
        let inv_count = 1.0 / count as f32;
        for j in 0..count {
            let (u, v) = match this_block {
                Some(b) => draws.point(i, b, j),
                None => (0.5, 0.5),
            };
            let w = if light.uses_w() {
                paths.stream[i].next_1d()
            } else {
                0.0
            };
            let Some(s) = light.sample(p, p_out, n, u, v, w) else {
                continue;
            };
            let contribution = beta * s.weight * (s.cos_surface * inv_count);
            if contribution.max_element() > 0.0 {
                shadow.push(i, p_out, s.direction, s.t_max, contribution);
            }
        }
    }
}

/// Direct lighting by uniform hemisphere sampling (`-H`): probe rays that
/// count the emission they find. N = lights × `-l` directions, pdf = 1/2π.
fn direct_hemisphere(
    inputs: &ShadeInputs,
    draws: &VertexDraws,
    i: usize,
    p: Vec3,
    n: Vec3,
    beta: Vec3,
    probes: &mut ShadowRays,
) {
    let count = inputs.lights.sources.len().max(1) as u32 * inputs.settings.light_samples;
    let scale = 2.0 * std::f32::consts::PI / count as f32;
    for j in 0..count {
        let (u, v) = draws.point(i, FIRST_LIGHT_BLOCK, j);
        let local = warp::uniform_hemisphere(u, v);
        let d = warp::to_world(local, n);
        probes.push(i, p, d, f32::INFINITY, beta * (local.z * scale));
    }
}

/// Samples the next direction (cosine-weighted: the Lambertian weight
/// f·cos/pdf is the albedo) and plays Russian roulette. Returns whether the
/// path survives.
///
/// Roulette: from vertex `settings.roulette_depth` on, a path continues with
/// probability q = min(1, max component of its throughput) and survivors
/// divide their throughput by q, so the expected contribution is unchanged.
fn continue_path(
    settings: &Settings,
    paths: &mut Paths,
    draws: &VertexDraws,
    i: usize,
    p: Vec3,
    n: Vec3,
    albedo: Vec3,
) -> bool {
    let mut throughput = paths.throughput[i] * albedo;
    if settings.russian_roulette && paths.depth[i] >= settings.roulette_depth {
        let q = throughput.max_element().min(1.0);
        if paths.stream[i].next_1d() >= q {
            return false;
        }
        throughput /= q;
    }
    if throughput.max_element() <= 0.0 || !throughput.is_finite() {
        return false;
    }
    let (u, v) = draws.point(i, BSDF_BLOCK, 0);
    let d = warp::to_world(warp::cosine_hemisphere(u, v), n);
    paths.throughput[i] = throughput;
    paths.depth[i] += 1;
    paths.specular[i] = false;
    paths.set_ray(i, p, d, f32::INFINITY);
    true
}
