//! Stage 3: shading. For every path that hit something: add emission,
//! draw light samples into shadow rays, sample the BSDF for the next ray,
//! and decide by Russian roulette whether the path goes on.
//!
//! Bounce accounting follows the reference: light found at path vertex `d`
//! (0 = the camera ray's hit) by emission has bounced `d` times; light
//! brought by next-event estimation at vertex `d` has bounced `d + 1` times.

use glam::Vec3;
use wide::f32x8;

use crate::integrator::bsdf::Surface;
use crate::integrator::environment::EnvironmentLight;
use crate::integrator::lights::{LightSamples, LightSet, LightSource};
use crate::integrator::{Settings, View};
use crate::lanes::{self, LANES, Vec3x8};
use crate::ray::{Hits, offset_by_x8};
use crate::sampling::rng::{VertexDraws, next_1d_x8};
use crate::sampling::warp;
use crate::scene::Geometry;

use super::paths::{Paths, ShadowRays, ShadowWriter};
use super::surface::{SurfacePoints, TriangleRecords};

/// Buffers the shade stage reuses from wave to wave.
#[derive(Clone, Debug, Default)]
pub struct ShadeScratch {
    draws: VertexDraws,
    surfaces: SurfacePoints,
    candidates: Vec<Candidate>,
    /// Where each path that escapes toward an environment map meets it.
    escapes: Vec<(f64, f64)>,
}

/// What the shade stage reads besides the paths.
pub struct ShadeInputs<'a> {
    pub geometry: &'a Geometry,
    /// The geometry's triangles as the surface stage reads them.
    pub triangles: &'a TriangleRecords,
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
/// the draws of each block are stratified across the pixel's samples.
fn vertex_blocks<'a>(inputs: &ShadeInputs<'a>, light: WaveLight) -> impl Iterator<Item = u32> + 'a {
    let settings = inputs.settings;
    let sources = &inputs.lights.sources;
    let probes = (light.probes > 0).then_some(light.probes);
    let lights = sources
        .iter()
        .filter(move |light| !settings.hemisphere && !light.is_delta())
        .map(move |_| settings.light_samples);
    std::iter::once(1).chain(probes).chain(lights)
}

/// What light a wave's paths can find, decided once per wave.
#[derive(Clone, Copy, Debug)]
struct WaveLight {
    /// Whether any ray can bring light to a path: some light emits, and
    /// with `-H` some emitting light can be hit (point and directional
    /// lights cannot be: no direction finds them). Where none can, no
    /// shadow, probe or continuation ray is traced.
    found: bool,
    /// Probe rays per vertex with `-H` (0 without it, or where none can
    /// find light): `-l` per light, dark ones included, as the reference
    /// counts them; all the emissive triangles together are one light
    /// here, each emissive sphere another.
    probes: u32,
}

impl WaveLight {
    fn of(inputs: &ShadeInputs) -> WaveLight {
        let (lights, settings) = (inputs.lights, inputs.settings);
        let found = if settings.hemisphere {
            lights.sources.iter().any(|light| !light.is_delta())
        } else {
            !lights.sources.is_empty()
        };
        let probes = if settings.hemisphere && found {
            (lights.sources.len() + lights.dark) as u32 * settings.light_samples
        } else {
            0
        };
        WaveLight { found, probes }
    }
}

/// Block of [`vertex_blocks`] that samples the BSDF.
const BSDF_BLOCK: usize = 0;
/// First block of light (or hemisphere-probe) samples.
const FIRST_LIGHT_BLOCK: usize = 1;

/// Shades every path of the wave. Paths that missed or ended are marked
/// not alive; live ones get their next ray.
///
/// Eight consecutive paths at a time: misses and emitter hits are handled
/// path by path (a few operations each), then the diffuse hits among the
/// eight — nearly all of them in a closed scene — are shaded together, one
/// path per SIMD lane, reading the surface points and draws straight from
/// their structure-of-arrays buffers.
pub fn shade(
    inputs: &ShadeInputs,
    hits: &Hits,
    paths: &mut Paths,
    scratch: &mut ShadeScratch,
    shadow: &mut ShadowRays,
    probes: &mut ShadowRays,
) {
    let settings = inputs.settings;
    let ShadeScratch {
        draws,
        surfaces,
        candidates,
        escapes,
    } = scratch;
    surfaces.compute(inputs.geometry, inputs.triangles, hits, &paths.rays);
    if settings.view != View::Path {
        show_view(settings.view, hits, surfaces, paths);
        return;
    }
    let light = WaveLight::of(inputs);
    draws.draw(&mut paths.stream, vertex_blocks(inputs, light));
    locate_escapes(inputs, hits, paths, escapes);
    let n = paths.len();
    let (mut shadow, mut probes) = (shadow.writer(), probes.writer());
    for start in (0..n).step_by(LANES) {
        let end = (start + LANES).min(n);
        let mut diffuse = 0u32;
        let (mut albedo, mut f) = ([Vec3::ZERO; LANES], [Vec3::ZERO; LANES]);
        for i in start..end {
            paths.alive[i] = false;
            if !hits.is_hit(i) {
                on_miss(inputs, paths, i, escapes);
                continue;
            }
            let depth = paths.depth[i];
            match inputs.surfaces[surfaces.material(i) as usize] {
                Surface::Emitter {
                    radiance,
                    one_sided,
                } => {
                    let seen = !one_sided || surfaces.front(i);
                    if seen && (depth == 0 || paths.specular[i]) && settings.counts_bounce(depth) {
                        paths.radiance[i] += paths.throughput[i] * radiance;
                    }
                }
                surface @ Surface::Diffuse { albedo: a } => {
                    diffuse |= 1 << (i - start);
                    albedo[i - start] = a;
                    f[i - start] = surface.f();
                }
            }
        }
        if diffuse != 0 {
            let chunk = Chunk {
                start,
                end,
                diffuse,
            };
            let brdf = (Vec3x8::gather(&albedo), Vec3x8::gather(&f));
            shade_diffuse(
                (inputs, light),
                (paths, draws, surfaces),
                &chunk,
                brdf,
                candidates,
                (&mut shadow, &mut probes),
            );
        }
    }
}

/// The views that show one thing about the first hit and end the path.
fn show_view(view: View, hits: &Hits, surfaces: &SurfacePoints, paths: &mut Paths) {
    for i in 0..paths.len() {
        paths.alive[i] = false;
        // The normal facing the viewer: outward on closed meshes, and into
        // the room for the Cornell boxes' walls, as the reference shows
        // them. (The bvh-cost view's film value was set by the caller.)
        if view == View::Normals && hits.is_hit(i) {
            paths.radiance[i] = 0.5 * (surfaces.get(i).ns + Vec3::ONE);
        }
    }
}

/// Eight consecutive paths `start..end` of a wave, with the mask of those
/// that hit a diffuse surface.
struct Chunk {
    start: usize,
    end: usize,
    diffuse: u32,
}

/// Shades the diffuse hits of a chunk (albedo and BRDF value per lane):
/// next-event estimation into shadow (or probe) rays, then the next
/// direction and Russian roulette.
fn shade_diffuse(
    (inputs, light): (&ShadeInputs, WaveLight),
    (paths, draws, surfaces): (&mut Paths, &VertexDraws, &SurfacePoints),
    chunk: &Chunk,
    (albedo, f): (Vec3x8, Vec3x8),
    candidates: &mut Vec<Candidate>,
    (shadow, probes): (&mut ShadowWriter, &mut ShadowWriter),
) {
    let settings = inputs.settings;
    let sp = surfaces.lanes(chunk.start);
    let p_out = offset_by_x8(sp.p, sp.ng, sp.err);
    let throughput = Vec3x8::gather(&paths.throughput[chunk.start..chunk.end]);
    // Lanes that gather direct light, and lanes that may go on.
    let (mut direct, mut goes_on) = (0u32, 0u32);
    let lit = light.found;
    for lane in lanes::each(chunk.diffuse) {
        let depth = paths.depth[chunk.start + lane];
        if lit && depth < settings.max_depth && settings.counts_bounce(depth + 1) {
            direct |= 1 << lane;
        }
        if lit && depth + 1 < settings.max_depth {
            goes_on |= 1 << lane;
        }
    }
    if direct != 0 {
        let beta = throughput * f;
        if settings.hemisphere {
            for lane in lanes::each(direct) {
                let i = chunk.start + lane;
                let (p, n, beta) = (p_out.lane(lane), sp.ns.lane(lane), beta.lane(lane));
                direct_hemisphere(light.probes, draws, i, p, n, beta, probes);
            }
        } else {
            let points = (sp.p, p_out, sp.ns);
            // Where a continuation ray may follow, it samples the
            // environment map too, and the two strategies share its light.
            let shared = match inputs.lights.environment {
                Some(_) => goes_on,
                None => 0,
            };
            let lanes = (direct, shared);
            direct_lights(
                inputs,
                paths,
                draws,
                chunk.start,
                lanes,
                points,
                beta,
                candidates,
            );
            push_shadow_rays(chunk.start, direct, p_out, candidates, shadow);
        }
    }
    if goes_on != 0 {
        let next = Continuation {
            origin: p_out,
            normal: sp.ns,
            throughput: throughput * albedo,
        };
        let escape = match inputs.lights.environment {
            None => Escape::NoMap,
            Some(_) if settings.hemisphere => Escape::Probed,
            Some(_) => Escape::Shared,
        };
        continue_paths(settings, paths, draws, chunk, goes_on, next, escape);
    }
}

/// The environment map that path `i`, which left the scene, sees, if it
/// is a camera ray or left a bounce whose multiple-importance weight
/// leaves the map's light a share (see [`on_miss`]).
fn sees_map<'a>(inputs: &'a ShadeInputs, paths: &Paths, i: usize) -> Option<&'a EnvironmentLight> {
    let environment = inputs.lights.environment.as_deref()?;
    (inputs.settings.counts_bounce(paths.depth[i]) && paths.escape_pdf[i] > 0.0)
        .then_some(environment)
}

/// Where each path of the wave that escapes toward the map meets it, a
/// pass of its own so that the texel lookups of all of them are
/// requested before the first is read (a map of 2048 columns is ~25 MB,
/// and most lookups miss the cache).
fn locate_escapes(inputs: &ShadeInputs, hits: &Hits, paths: &Paths, escapes: &mut Vec<(f64, f64)>) {
    let Some(environment) = inputs.lights.environment.as_deref() else {
        return;
    };
    // Only entries written below are read (by `on_miss`, under the same
    // `sees_map`), so a longer buffer's stale ones need no clearing.
    escapes.resize(paths.len(), (0.0, 0.0));
    // Four at a time: the positions' arc tangents and cosines are
    // computed in vector lanes.
    let (mut members, mut directions, mut count) = ([0; 4], [Vec3::ZERO; 4], 0);
    for i in 0..=paths.len() {
        let done = i == paths.len();
        if !done {
            if hits.is_hit(i) || sees_map(inputs, paths, i).is_none() {
                continue;
            }
            (members[count], directions[count]) = (i, paths.rays.direction(i));
            count += 1;
        }
        if count == 4 || (done && count > 0) {
            let found = environment.locate_lanes(directions, count);
            for k in 0..count {
                escapes[members[k]] = found[k];
            }
            count = 0;
        }
    }
}

/// A ray that left the scene sees what lies beyond it if it is a camera
/// ray (the environment map only) or left a delta bounce (the map and the
/// sky): after any other bounce, next-event estimation has counted that
/// light already — but for the environment map's share that its
/// multiple-importance weight leaves to the BSDF's ray. The map's position
/// is where [`locate_escapes`] found it.
fn on_miss(inputs: &ShadeInputs, paths: &mut Paths, i: usize, escapes: &[(f64, f64)]) {
    let depth = paths.depth[i];
    let settings = inputs.settings;
    if !settings.counts_bounce(depth) {
        return;
    }
    let sky = depth > 0 && paths.specular[i];
    let map = sees_map(inputs, paths, i);
    if sky || map.is_some() {
        let d = paths.rays.direction(i);
        let mut arriving = if sky {
            inputs.lights.sky_toward(d)
        } else {
            Vec3::ZERO
        };
        if let Some(environment) = map {
            let at = escapes[i];
            arriving += environment.escaping_at(at, paths.escape_pdf[i], settings.light_samples);
        }
        paths.radiance[i] += paths.throughput[i] * arriving;
    }
}

/// One light sample for each of a chunk's lanes: the shadow ray it asks
/// for and what it brings if unoccluded.
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    direction: Vec3x8,
    t_max: f32x8,
    contribution: Vec3x8,
    /// Lanes whose ray is worth tracing (non-zero contribution).
    valid: u32,
}

/// Next-event estimation for the lanes in `direct`: `-l` samples per
/// area-like light, one per delta light, into `candidates` in light and
/// sample order. Distances and angles are measured from the surface
/// points `p`; only the shadow rays start from the offset points `p_out`,
/// so the offset (large where the error bound is: 1 on a 2e6-wide ground
/// plane) cannot bias the lighting.
#[allow(clippy::too_many_arguments)]
fn direct_lights(
    inputs: &ShadeInputs,
    paths: &mut Paths,
    draws: &VertexDraws,
    start: usize,
    (direct, shared): (u32, u32),
    (p, p_out, n): (Vec3x8, Vec3x8, Vec3x8),
    beta: Vec3x8,
    candidates: &mut Vec<Candidate>,
) {
    candidates.clear();
    let mut block = FIRST_LIGHT_BLOCK;
    for light in &inputs.lights.sources {
        // The `-l` samples of one light come from one stratified block.
        let (count, this_block) = if light.is_delta() {
            (1, None)
        } else {
            block += 1;
            (inputs.settings.light_samples, Some(block - 1))
        };
        let inv_count = f32x8::splat(1.0 / count as f32);
        for j in 0..count {
            let (u, v) = match this_block {
                Some(b) => draws.lanes(start, b, j),
                None => (f32x8::splat(0.5), f32x8::splat(0.5)),
            };
            let s = light.sample_x8((p, p_out, n), u, v).unwrap_or_else(|| {
                let mis = (shared, count);
                sample_lanes(light, paths, (start, direct), mis, (p, p_out, n), (u, v))
            });
            let contribution = beta * s.weight * (s.cos_surface * inv_count);
            let positive = contribution.max_element().simd_gt(f32x8::ZERO).to_bitmask();
            candidates.push(Candidate {
                direction: s.direction,
                t_max: s.t_max,
                contribution,
                valid: s.valid & positive & direct,
            });
        }
    }
}

/// [`LightSource::sample`] lane by lane, for the lights without an
/// eight-lane form; meshes take the bits that pick a triangle from each
/// path's stream, and environment maps the bits that place a point in a
/// cell. An environment map's samples in the lanes `shared` (whose
/// continuation ray may find the map as well) are weighted by their
/// multiple-importance share against that ray, for `count` map samples
/// per vertex.
fn sample_lanes(
    light: &LightSource,
    paths: &mut Paths,
    (start, direct): (usize, u32),
    (shared, count): (u32, u32),
    (p, p_out, n): (Vec3x8, Vec3x8, Vec3x8),
    (u, v): (f32x8, f32x8),
) -> LightSamples {
    let mut out = [None; LANES];
    let mut draws = [(0.0, 0.0, 0); LANES];
    for lane in lanes::each(direct) {
        let pick = if light.uses_pick() {
            paths.stream[start + lane].next_u32()
        } else {
            0
        };
        draws[lane] = (u.as_array()[lane], v.as_array()[lane], pick);
    }
    if let LightSource::Environment(environment) = light {
        let samples = environment.sample_lanes(direct, &draws);
        for lane in lanes::each(direct) {
            let shared_with = (shared & (1 << lane) != 0).then_some(count);
            out[lane] = environment.light_sample(n.lane(lane), &samples[lane], shared_with);
        }
    } else {
        for lane in lanes::each(direct) {
            let (u, v, pick) = draws[lane];
            out[lane] = light.sample(p.lane(lane), p_out.lane(lane), n.lane(lane), u, v, pick);
        }
    }
    LightSamples::from_lanes(&out)
}

/// Pushes the chunk's shadow rays path by path, each path's in light and
/// sample order: the rays of one vertex stay consecutive (they share an
/// origin, so they mostly fall in the same batch slots and walk the tree
/// as bundles), and each path adds up its light in the same order whatever
/// the lane layout.
fn push_shadow_rays(
    start: usize,
    direct: u32,
    p_out: Vec3x8,
    candidates: &[Candidate],
    shadow: &mut ShadowWriter,
) {
    for lane in lanes::each(direct) {
        let origin = p_out.lane(lane);
        for c in candidates.iter().filter(|c| c.valid & (1 << lane) != 0) {
            shadow.push(
                start + lane,
                origin,
                c.direction.lane(lane),
                c.t_max.as_array()[lane],
                c.contribution.lane(lane),
            );
        }
    }
}

/// Direct lighting by uniform hemisphere sampling (`-H`): `count` probe
/// rays that count the emission they find (N = lights × `-l` directions,
/// see [`WaveLight::probes`]), pdf = 1/2π.
fn direct_hemisphere(
    count: u32,
    draws: &VertexDraws,
    i: usize,
    p: Vec3,
    n: Vec3,
    beta: Vec3,
    probes: &mut ShadowWriter,
) {
    let scale = 2.0 * std::f32::consts::PI / count as f32;
    for j in 0..count {
        let (u, v) = draws.point(i, FIRST_LIGHT_BLOCK, j);
        let local = warp::uniform_hemisphere(u, v);
        let d = warp::to_world(local, n);
        probes.push(i, p, d, f32::INFINITY, beta * (local.z * scale));
    }
}

/// Where the chunk's paths would go on from: the offset points, the
/// shading normals, and the throughput times the albedo.
struct Continuation {
    origin: Vec3x8,
    normal: Vec3x8,
    throughput: Vec3x8,
}

/// Samples the next direction of the lanes in `goes_on` (cosine-weighted:
/// the Lambertian weight f·cos/pdf is the albedo, already in
/// `next.throughput`) and plays Russian roulette; sets each survivor's
/// next ray and marks it alive.
///
/// Roulette: from vertex `settings.roulette_depth` on, a path continues with
/// probability q = min(1, max component of its throughput) and survivors
/// divide their throughput by q, so the expected contribution is unchanged.
fn continue_paths(
    settings: &Settings,
    paths: &mut Paths,
    draws: &VertexDraws,
    chunk: &Chunk,
    goes_on: u32,
    next: Continuation,
    escape: Escape,
) {
    let start = chunk.start;
    let mut throughput = next.throughput;
    let mut alive = goes_on;
    if settings.russian_roulette {
        let roulette = lanes::each(goes_on)
            .filter(|&l| paths.depth[start + l] >= settings.roulette_depth)
            .fold(0u32, |m, l| m | 1 << l);
        if roulette != 0 {
            let q = throughput.max_element().min(f32x8::ONE);
            let xi = next_1d_x8(&mut paths.stream[start..chunk.end], roulette);
            alive &= !(xi.simd_ge(q).to_bitmask() & roulette);
            let in_roulette = lanes::lane_mask(roulette);
            throughput = Vec3x8::select(in_roulette, throughput / q, throughput);
        }
    }
    let bad = throughput.max_element().simd_le(f32x8::ZERO) | !throughput.is_finite();
    alive &= !bad.to_bitmask();
    if alive == 0 {
        return;
    }
    let (u, v) = draws.lanes(start, BSDF_BLOCK, 0);
    let d = warp::to_world_x8(warp::cosine_hemisphere_x8(u, v), next.normal);
    // Every lane's ray is written (the dead ones' are never read).
    let end = chunk.end;
    let r = &mut paths.rays;
    next.origin
        .store([&mut r.org_x, &mut r.org_y, &mut r.org_z], start, end);
    d.store([&mut r.dir_x, &mut r.dir_y, &mut r.dir_z], start, end);
    lanes::store(&mut r.t_max[..end], start, f32x8::splat(f32::INFINITY));
    for lane in lanes::each(alive) {
        let i = start + lane;
        paths.throughput[i] = throughput.lane(lane);
        paths.depth[i] += 1;
        paths.specular[i] = false;
        paths.alive[i] = true;
    }
    match escape {
        Escape::NoMap => {}
        Escape::Probed => {
            for lane in lanes::each(alive) {
                paths.escape_pdf[start + lane] = 0.0;
            }
        }
        Escape::Shared => {
            // Cosine-weighted: density cos θ / π. (The map's density, for
            // the share, is looked up only if the ray escapes.)
            let pdf = (d.dot(next.normal) * f32x8::splat(std::f32::consts::FRAC_1_PI)).to_array();
            for lane in lanes::each(alive) {
                paths.escape_pdf[start + lane] = pdf[lane];
            }
        }
    }
}

/// How a continuation ray counts the environment map's light if it
/// escapes ([`Paths::escape_pdf`]).
enum Escape {
    /// There is no map (the densities are never read).
    NoMap,
    /// Not at all: hemisphere probes (`-H`) count it.
    Probed,
    /// By its multiple-importance share against the map's samples.
    Shared,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Triangles;

    /// The draw blocks a vertex takes: the BSDF's, then `-l` per area-like
    /// light, or with `-H` one block of all the probes, where a probe can
    /// find light. (A block drawn and never used would only move the
    /// others' dimensions, which no image mean can show.)
    #[test]
    fn vertices_draw_a_block_per_use() {
        let point = LightSource::Point {
            position: Vec3::Y,
            intensity: Vec3::ONE,
        };
        let sky = LightSource::Hemisphere {
            radiance: Vec3::ONE,
        };
        let triangles = TriangleRecords::new(&Triangles::default());
        let blocks = |sources: Vec<LightSource>, dark: usize, hemisphere: bool| {
            let lights = LightSet {
                sources,
                dark,
                ..LightSet::default()
            };
            let settings = Settings {
                hemisphere,
                light_samples: 3,
                ..Settings::default()
            };
            let inputs = ShadeInputs {
                geometry: &Geometry::default(),
                triangles: &triangles,
                surfaces: &[],
                lights: &lights,
                settings: &settings,
            };
            vertex_blocks(&inputs, WaveLight::of(&inputs)).collect::<Vec<u32>>()
        };
        // Light sampling: -l draws for the sky, none for the point light.
        assert_eq!(blocks(vec![point.clone(), sky.clone()], 1, false), [1, 3]);
        assert_eq!(blocks(vec![point.clone()], 0, false), [1]);
        // -H: one block of (lights + dark) × -l probes, or none where no
        // probe can find light.
        assert_eq!(blocks(vec![point.clone(), sky], 1, true), [1, 9]);
        assert_eq!(blocks(vec![point], 1, true), [1]);
        assert_eq!(blocks(vec![], 0, true), [1]);
    }
}
