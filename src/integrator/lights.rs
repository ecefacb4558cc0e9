//! Light sampling for next-event estimation.
//!
//! Every emitter becomes a [`LightSource`] that can draw a point or
//! direction as seen from a shading point and report the incident radiance
//! divided by the solid-angle pdf of that choice. Emissive meshes are one
//! source per scene, their triangles chosen in proportion to area.

use std::sync::Arc;

use glam::Vec3;
use wide::f32x8;

use super::bsdf::Surface;
use super::environment::EnvironmentLight;
use crate::bvh::END_CLEARANCE;
use crate::lanes::{LANES, Vec3x8, normalize_any_scale};
use crate::ray::{gamma, offset_by, offset_by_x8};
use crate::sampling::slots::SlotTable;
use crate::sampling::warp;
use crate::scene::{Light, Scene};

/// A sampled connection from a shading point to a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unnormalised direction from the shadow ray's (offset) origin to the light.
    pub direction: Vec3,
    /// Extent of the shadow ray along `direction`.
    pub t_max: f32,
    /// Incident radiance divided by the solid-angle pdf.
    pub weight: Vec3,
    /// Cosine between the surface normal and the direction to the light.
    pub cos_surface: f32,
}

#[derive(Clone, Debug)]
pub enum LightSource {
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Directional {
        to_light: Vec3,
        radiance: Vec3,
    },
    Rectangle {
        center: Vec3,
        normal: Vec3,
        dim_x: Vec3,
        dim_y: Vec3,
        radiance: Vec3,
        area: f32,
        /// How far a sampled point may be from the plane of the light's
        /// two triangles (corners center ± dim/2, rounded): γ₅ of the
        /// magnitudes that went into both.
        q_err: f32,
        /// Largest distance along an axis from any point of the light to its
        /// corners.
        extent: f32,
        /// Largest coordinate magnitude in the scene (see `connect_x8`).
        scene_extent: f32,
    },
    Hemisphere {
        radiance: Vec3,
    },
    /// Emissive sphere, sampled uniformly in the cone it subtends.
    Sphere {
        center: Vec3,
        radius: f32,
        radiance: Vec3,
    },
    /// An environment map, sampled in proportion to its light.
    Environment(Arc<EnvironmentLight>),
    /// Two-sided emissive triangles, sampled by area.
    Mesh {
        /// Vertex positions per triangle.
        triangles: Vec<[Vec3; 3]>,
        radiance: Vec<Vec3>,
        /// How a 32-bit draw picks a triangle and how likely each is.
        pick: TrianglePick,
        /// Largest coordinate magnitude in the scene (see `connect_x8`).
        scene_extent: f32,
    },
}

impl LightSource {
    /// Whether a single sample is exact (delta lights need only one).
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            LightSource::Point { .. } | LightSource::Directional { .. }
        )
    }

    /// Whether [`sample`](Self::sample) uses its 32 random bits `pick`
    /// (to pick a triangle, or a point in an environment map's cell);
    /// the other lights use none of them.
    pub fn uses_pick(&self) -> bool {
        matches!(self, LightSource::Mesh { .. } | LightSource::Environment(_))
    }

    /// Draws a connection from surface point `p` (normal `n`) with random
    /// numbers `(u, v)` and, for meshes, the random bits `pick` to choose a
    /// triangle. The weight
    /// and cosine are measured from `p`; the shadow ray starts at `origin`,
    /// `p` moved off its surface. `None` when the light cannot reach `p`.
    ///
    /// The shading stage calls this only for the lights without an
    /// eight-lane form ([`sample_x8`](Self::sample_x8)).
    pub fn sample(
        &self,
        p: Vec3,
        origin: Vec3,
        n: Vec3,
        u: f32,
        v: f32,
        pick: u32,
    ) -> Option<LightSample> {
        match self {
            LightSource::Sphere {
                center,
                radius,
                radiance,
            } => sample_sphere(p, origin, n, *center, *radius, *radiance, u, v),
            LightSource::Environment(environment) => {
                environment.light_sample(n, &environment.sample(u, v, pick), None)
            }
            LightSource::Mesh {
                triangles,
                radiance,
                pick: choice,
                scene_extent,
            } => {
                let i = choice.triangle(pick);
                let [a, b, c] = triangles[i];
                // Uniform point on the triangle (square-root warp).
                let su = u.sqrt();
                let q = a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v);
                let q_err = gamma(7) * a.abs().max(b.abs()).max(c.abs()).max_element();
                let extent = (a - q).abs().max((b - q).abs()).max((c - q).abs());
                // Two-sided: the normal that faces p.
                let ng = normalize_any_scale((b - a).cross(c - a)).unwrap_or(Vec3::ZERO);
                let facing = if ng.dot(p - q) >= 0.0 { ng } else { -ng };
                let x8 = Vec3x8::splat;
                connect_x8(
                    (x8(p), x8(origin), x8(n)),
                    (
                        x8(q),
                        f32x8::splat(q_err),
                        f32x8::splat(extent.max_element()),
                    ),
                    x8(facing),
                    (choice.area_over_probability[i], *scene_extent),
                    x8(radiance[i]),
                )
                .lane(0)
            }
            _ => self
                .sample_x8(
                    (Vec3x8::splat(p), Vec3x8::splat(origin), Vec3x8::splat(n)),
                    f32x8::splat(u),
                    f32x8::splat(v),
                )
                .and_then(|s| s.lane(0)),
        }
    }

    /// [`sample`](Self::sample) at eight shading points at once, for the
    /// lights that need no third random number and have an eight-lane
    /// form (point, directional, rectangle, hemisphere: all but spheres
    /// and meshes, which return `None`). This is the definition of those
    /// lights' sampling; the one-point `sample` runs it in one lane.
    #[inline(always)]
    pub fn sample_x8(
        &self,
        (p, origin, n): (Vec3x8, Vec3x8, Vec3x8),
        u: f32x8,
        v: f32x8,
    ) -> Option<LightSamples> {
        let x8 = Vec3x8::splat;
        let zero = f32x8::ZERO;
        Some(match self {
            LightSource::Point {
                position,
                intensity,
            } => {
                let d = x8(*position) - p;
                let dist2 = d.length_squared();
                let cos_surface = n.dot(d) / dist2.sqrt();
                LightSamples {
                    direction: x8(*position) - origin,
                    t_max: f32x8::ONE,
                    weight: x8(*intensity) / dist2,
                    cos_surface,
                    valid: (dist2.simd_gt(zero) & cos_surface.simd_gt(zero)).to_bitmask(),
                }
            }
            LightSource::Directional { to_light, radiance } => {
                let cos_surface = n.dot(x8(*to_light));
                LightSamples {
                    direction: x8(*to_light),
                    t_max: f32x8::splat(f32::INFINITY),
                    weight: x8(*radiance),
                    cos_surface,
                    valid: cos_surface.simd_gt(zero).to_bitmask(),
                }
            }
            LightSource::Rectangle {
                center,
                normal,
                dim_x,
                dim_y,
                radiance,
                area,
                q_err,
                extent,
                scene_extent,
            } => {
                let half = f32x8::splat(0.5);
                let q = x8(*center) + x8(*dim_x) * (u - half) + x8(*dim_y) * (v - half);
                // One-sided: light leaves toward `normal` only.
                connect_x8(
                    (p, origin, n),
                    (q, f32x8::splat(*q_err), f32x8::splat(*extent)),
                    x8(*normal),
                    (*area, *scene_extent),
                    x8(*radiance),
                )
            }
            LightSource::Hemisphere { radiance } => {
                // Cosine-weighted about the surface normal; only upward directions see the sky.
                let d = warp::to_world_x8(warp::cosine_hemisphere_x8(u, v), n);
                let cos = d.dot(n);
                LightSamples {
                    direction: d,
                    t_max: f32x8::splat(f32::INFINITY),
                    weight: x8(*radiance) * (f32x8::splat(std::f32::consts::PI) / cos),
                    cos_surface: cos,
                    valid: !(d.y.simd_le(zero) | cos.simd_le(zero)).to_bitmask() & 0xff,
                }
            }
            LightSource::Sphere { .. } | LightSource::Mesh { .. } | LightSource::Environment(_) => {
                return None;
            }
        })
    }
}

/// Eight [`LightSample`]s, one per lane; `valid` has bit `l` set where
/// lane `l`'s light can reach its shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSamples {
    pub direction: Vec3x8,
    pub t_max: f32x8,
    pub weight: Vec3x8,
    pub cos_surface: f32x8,
    pub valid: u32,
}

impl LightSamples {
    /// Eight one-point samples side by side (`None`: not valid).
    pub fn from_lanes(samples: &[Option<LightSample>; LANES]) -> LightSamples {
        let vector = |f: fn(&LightSample) -> Vec3| {
            Vec3x8::from_fn(LANES, |l| samples[l].as_ref().map_or(Vec3::ZERO, f))
        };
        let scalar =
            |f: fn(&LightSample) -> f32| f32x8::from(samples.map(|s| s.as_ref().map_or(0.0, f)));
        LightSamples {
            direction: vector(|s| s.direction),
            t_max: scalar(|s| s.t_max),
            weight: vector(|s| s.weight),
            cos_surface: scalar(|s| s.cos_surface),
            valid: (0..LANES).fold(0, |m, l| m | (u32::from(samples[l].is_some()) << l)),
        }
    }

    /// The sample of `lane`, if valid.
    #[inline]
    pub fn lane(&self, lane: usize) -> Option<LightSample> {
        (self.valid & (1 << lane) != 0).then(|| LightSample {
            direction: self.direction.lane(lane),
            t_max: self.t_max.as_array()[lane],
            weight: self.weight.lane(lane),
            cos_surface: self.cos_surface.as_array()[lane],
        })
    }
}

/// Samples the sphere from `p`: uniformly in its cone of directions from
/// outside (pdf = 1 / 2π(1 − cos θmax)), uniformly over all directions from
/// inside (pdf = 1 / 4π). The shadow ray ends just before the surface.
#[allow(clippy::too_many_arguments)]
fn sample_sphere(
    p: Vec3,
    origin: Vec3,
    n: Vec3,
    center: Vec3,
    radius: f32,
    radiance: Vec3,
    u: f32,
    v: f32,
) -> Option<LightSample> {
    let to_center = center - p;
    let dist2 = to_center.length_squared();
    let r2 = radius * radius;
    let (dir, pdf) = if dist2 > r2 {
        let sin2_max = r2 / dist2;
        // 1 − cos θmax, computed stably for small cones.
        let one_minus_cos_max = if sin2_max < 1e-4 {
            0.5 * sin2_max * (1.0 + 0.25 * sin2_max)
        } else {
            1.0 - (1.0 - sin2_max).max(0.0).sqrt()
        };
        let cos_theta = 1.0 - u * one_minus_cos_max;
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let (c, s) = warp::unit_circle(v);
        let axis = to_center / dist2.sqrt();
        let local = Vec3::new(sin_theta * c, sin_theta * s, cos_theta);
        (
            warp::to_world(local, axis),
            1.0 / (2.0 * std::f32::consts::PI * one_minus_cos_max),
        )
    } else {
        let z = 1.0 - 2.0 * u;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (c, s) = warp::unit_circle(v);
        (
            Vec3::new(r * c, r * s, z),
            1.0 / (4.0 * std::f32::consts::PI),
        )
    };
    // Distance to the sphere along `dir` (near root outside, far root inside),
    // in the numerically stable form of the quadratic.
    let b = dir.dot(to_center);
    let c = dist2 - r2;
    let disc = (b * b - c).max(0.0);
    let q = b + b.signum() * disc.sqrt();
    // Outside (c > 0) both roots are positive and c/q is the nearer; inside
    // they have opposite signs and the larger is the exit point.
    let t = if c > 0.0 { c / q } else { q.max(c / q) };
    if !(t > 0.0 && t.is_finite()) {
        return None;
    }
    let n_light = (p + t * dir - center).normalize_or_zero();
    // Reprojected onto the sphere, as for camera hits (shade.rs).
    let hit = center + radius * n_light;
    let facing = if n_light.dot(p - hit) >= 0.0 {
        n_light
    } else {
        -n_light
    };
    // Stop short of the sphere by the error of `hit` (γ of |center| + r)
    // plus that of the ray/sphere test from `origin`, whose root errs by
    // ~γ times the distance to the sphere.
    let err = gamma(8) * (center.abs().max_element() + radius + (hit - origin).abs().max_element());
    let end = offset_by(hit, facing, err);
    let cos_surface = n.dot(dir);
    (cos_surface > 0.0).then(|| LightSample {
        direction: end - origin,
        t_max: 1.0,
        weight: radiance / pdf,
        cos_surface,
    })
}

/// A connection from `p` (surface normal `n`) to point `q` on an area
/// emitter of normal `n_light`, which emits only toward its side:
/// pdf in solid angle = d² / (area · cos θ_light). One square root and one
/// division serve both cosines and the pdf. The shadow ray runs from
/// `origin` to just in front of `q`, which lies within `q_err` of the
/// emitter's triangles, all of whose vertices are within `extent` of `q`.
///
/// It ends short of the emitter's plane by more than those rounding
/// errors: by the BVH's [`END_CLEARANCE`] of the coordinates involved
/// (the ray's reach, its origin and `scene_extent`), so that the emitter's
/// own box, when it is flat (an axis-aligned rectangle light, as in the
/// Cornell boxes) and so lies in the plane the ray ends at, is culled by
/// the traversal rather than entered and its triangles tested, for every
/// shadow ray. That clearance grows with the
/// coordinates, not with the ray, so it is capped at [`MAX_CLEARANCE`] of
/// the ray's reach (pbrt's shadow epsilon): far from the origin, where the
/// float grid is coarse, the cap applies and the emitter's box is entered
/// as before. An occluder closer to the emitter than the clearance casts
/// no shadow.
#[inline(always)]
fn connect_x8(
    (p, origin, n): (Vec3x8, Vec3x8, Vec3x8),
    (q, q_err, extent): (Vec3x8, f32x8, f32x8),
    n_light: Vec3x8,
    (area, scene_extent): (f32, f32),
    radiance: Vec3x8,
) -> LightSamples {
    let d = q - p;
    let dist2 = d.length_squared();
    let inv_dist = f32x8::ONE / dist2.sqrt();
    let cos_light = -n_light.dot(d) * inv_dist;
    let cos_surface = n.dot(d) * inv_dist;
    let valid = cos_light.simd_gt(f32x8::ZERO) & cos_surface.simd_gt(f32x8::ZERO);
    // End the shadow ray just in front of the emitter so it cannot hit it:
    // beyond q's own error, and beyond the rounding of the ray/triangle
    // test from `origin`, ~γ₈ times the distance to the emitter's far corner.
    let reach = (q - origin).abs().max_element() + extent;
    let clearance = (f32x8::splat(END_CLEARANCE)
        * (reach + origin.abs().max_element() + f32x8::splat(scene_extent)))
    .fast_min(f32x8::splat(MAX_CLEARANCE) * reach);
    let end = offset_by_x8(
        q,
        n_light,
        q_err + f32x8::splat(gamma(8)) * reach + clearance,
    );
    LightSamples {
        direction: end - origin,
        t_max: f32x8::ONE,
        weight: radiance * (f32x8::splat(area) * cos_light * inv_dist * inv_dist),
        cos_surface,
        valid: valid.to_bitmask(),
    }
}

/// Largest shortening of a shadow ray for [`END_CLEARANCE`], relative to
/// its reach.
const MAX_CLEARANCE: f32 = 1e-4;

/// Every light source of a scene.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub sources: Vec<LightSource>,
    /// Summed radiance of hemisphere lights, seen by rays that escape upward.
    pub sky: Vec3,
    /// The environment map (also among `sources`), seen by rays that escape.
    pub environment: Option<Arc<EnvironmentLight>>,
    /// The scene's lights of colour 0, left out of `sources`. Uniform
    /// hemisphere sampling still counts them: its N is lights × `-l`.
    pub dark: usize,
}

impl LightSet {
    pub fn new(scene: &Scene, surfaces: &[Surface]) -> LightSet {
        let mut set = LightSet::default();
        let scene_extent = scene.geometry.bounds().max_abs();
        for light in &scene.lights {
            // A light of colour 0 would only cost shadow rays (an area
            // light's rectangle stays in the geometry all the same).
            if !light.emits() {
                set.dark += 1;
                continue;
            }
            set.sources.push(match *light {
                Light::Point {
                    position,
                    intensity,
                } => LightSource::Point {
                    position,
                    intensity,
                },
                Light::Directional { to_light, radiance } => {
                    LightSource::Directional { to_light, radiance }
                }
                Light::Area {
                    center,
                    dim_x,
                    dim_y,
                    radiance,
                    ..
                } => LightSource::Rectangle {
                    center,
                    normal: light.emitting_normal().unwrap_or(Vec3::NEG_Y),
                    dim_x,
                    dim_y,
                    radiance,
                    area: light.area(),
                    q_err: gamma(5)
                        * (center.abs() + 0.5 * dim_x.abs() + 0.5 * dim_y.abs()).max_element(),
                    extent: (dim_x.abs() + dim_y.abs()).max_element(),
                    scene_extent,
                },
                Light::Hemisphere { radiance } => {
                    set.sky += radiance;
                    LightSource::Hemisphere { radiance }
                }
                Light::Environment(ref map) => {
                    // `emits` above: a map that sends light has tables.
                    let environment =
                        Arc::new(EnvironmentLight::new(map.clone()).expect("the map emits"));
                    set.environment = Some(environment.clone());
                    LightSource::Environment(environment)
                }
            });
        }
        // Emissive spheres.
        let spheres = &scene.geometry.spheres;
        for i in 0..spheres.len() {
            if let Surface::Emitter { radiance, .. } = surfaces[spheres.material[i] as usize]
                && radiance.max_element() > 0.0
            {
                set.sources.push(LightSource::Sphere {
                    center: spheres.center[i],
                    radius: spheres.radius[i],
                    radiance,
                });
            }
        }
        // Emissive meshes (area-light rectangles are sampled as rectangles above).
        let tris = &scene.geometry.triangles;
        let (mut triangles, mut radiance, mut areas) = (Vec::new(), Vec::new(), Vec::new());
        for t in 0..tris.len() {
            if let Surface::Emitter {
                radiance: le,
                one_sided: false,
            } = surfaces[tris.material[t] as usize]
            {
                // In f64: the squared length of a 1e10-wide triangle's normal
                // overflows f32.
                let area = 0.5 * tris.geometric_normal(t).as_dvec3().length();
                if area > 0.0 && le.max_element() > 0.0 {
                    triangles.push(tris.vertices(t));
                    radiance.push(le);
                    areas.push(area);
                }
            }
        }
        if !triangles.is_empty() {
            set.sources.push(LightSource::Mesh {
                triangles,
                radiance,
                pick: TrianglePick::by_area(&areas),
                scene_extent,
            });
        }
        set
    }

    pub fn is_empty(&self) -> bool {
        self.sources.is_empty()
    }

    /// The sky's radiance (hemisphere lights) arriving along `d`.
    #[inline]
    pub fn sky_toward(&self, d: Vec3) -> Vec3 {
        if d.y > 0.0 { self.sky } else { Vec3::ZERO }
    }
}

/// How an emissive mesh's light samples choose a triangle: by area, from
/// 32 random bits (a [`SlotTable`] of 2³² slots), with each triangle's
/// probability known exactly. A sample is weighted by its triangle's area
/// over that probability, so the estimate is unbiased however the shares
/// round. (A cumulative table of f32 searched with a 24-bit draw gave the
/// triangles of a million-triangle mesh probabilities up to ±6% off their
/// weights, and left triangles under 2⁻²⁴ of the area out altogether.)
#[derive(Clone, Debug)]
pub struct TrianglePick {
    slots: SlotTable,
    /// Each triangle's area divided by its probability of being chosen.
    area_over_probability: Vec<f32>,
}

impl TrianglePick {
    const SLOTS: u64 = 1 << 32;

    /// The pick among triangles of areas `areas` (positive; at least one
    /// and fewer than 2³²).
    pub fn by_area(areas: &[f64]) -> TrianglePick {
        let n = areas.len() as u64;
        assert!(
            n > 0 && n < Self::SLOTS && areas.iter().all(|&a| a > 0.0),
            "{n} triangles"
        );
        let slots = SlotTable::new(areas, Self::SLOTS).expect("positive areas");
        let area_over_probability = areas
            .iter()
            .enumerate()
            .map(|(i, &area)| {
                let owned = slots.slots(i);
                (area * Self::SLOTS as f64 / (owned.end - owned.start) as f64) as f32
            })
            .collect();
        TrianglePick {
            slots,
            area_over_probability,
        }
    }

    /// The triangle that the random bits `pick` choose.
    #[inline]
    pub fn triangle(&self, pick: u32) -> usize {
        self.slots.choose(u64::from(pick))
    }

    /// The probability that triangle `i` is chosen.
    pub fn probability(&self, i: usize) -> f64 {
        self.slots.probability(i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-point formulas the eight-lane forms replaced, kept as the
    /// reference they must reproduce bit for bit.
    fn scalar_sample(
        light: &LightSource,
        p: Vec3,
        origin: Vec3,
        n: Vec3,
        u: f32,
        v: f32,
    ) -> Option<LightSample> {
        match light {
            LightSource::Point {
                position,
                intensity,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let cos_surface = n.dot(d) / dist2.sqrt();
                (dist2 > 0.0 && cos_surface > 0.0).then(|| LightSample {
                    direction: *position - origin,
                    t_max: 1.0,
                    weight: *intensity / dist2,
                    cos_surface,
                })
            }
            LightSource::Directional { to_light, radiance } => {
                let cos_surface = n.dot(*to_light);
                (cos_surface > 0.0).then_some(LightSample {
                    direction: *to_light,
                    t_max: f32::INFINITY,
                    weight: *radiance,
                    cos_surface,
                })
            }
            LightSource::Rectangle {
                center,
                normal,
                dim_x,
                dim_y,
                radiance,
                area,
                q_err,
                extent,
                scene_extent,
            } => {
                let q = *center + (u - 0.5) * *dim_x + (v - 0.5) * *dim_y;
                let d = q - p;
                let dist2 = d.length_squared();
                let inv_dist = dist2.sqrt().recip();
                let cos_light = -normal.dot(d) * inv_dist;
                let cos_surface = n.dot(d) * inv_dist;
                if !(cos_light > 0.0 && cos_surface > 0.0) {
                    return None;
                }
                let reach = (q - origin).abs().max_element() + extent;
                let clearance = (END_CLEARANCE
                    * (reach + origin.abs().max_element() + scene_extent))
                    .min(MAX_CLEARANCE * reach);
                let end = offset_by(q, *normal, q_err + gamma(8) * reach + clearance);
                Some(LightSample {
                    direction: end - origin,
                    t_max: 1.0,
                    weight: *radiance * (area * cos_light * inv_dist * inv_dist),
                    cos_surface,
                })
            }
            LightSource::Hemisphere { radiance } => {
                let d = warp::to_world(warp::cosine_hemisphere(u, v), n);
                let cos = d.dot(n);
                if d.y <= 0.0 || cos <= 0.0 {
                    return None;
                }
                Some(LightSample {
                    direction: d,
                    t_max: f32::INFINITY,
                    weight: *radiance * (std::f32::consts::PI / cos),
                    cos_surface: cos,
                })
            }
            _ => unreachable!(),
        }
    }

    /// Every light with an eight-lane form gives, in each lane, exactly
    /// what the one-point formula gives for that lane's inputs.
    #[test]
    fn lanes_sample_independently() {
        let lights = [
            LightSource::Point {
                position: Vec3::new(0.0, 2.0, 0.0),
                intensity: Vec3::new(3.0, 2.0, 1.0),
            },
            LightSource::Directional {
                to_light: Vec3::new(0.0, 0.6, 0.8),
                radiance: Vec3::ONE,
            },
            LightSource::Rectangle {
                center: Vec3::new(0.0, 2.0, 0.0),
                normal: Vec3::NEG_Y,
                dim_x: Vec3::new(0.5, 0.0, 0.0),
                dim_y: Vec3::new(0.0, 0.0, 0.25),
                radiance: Vec3::splat(4.0),
                area: 0.125,
                q_err: gamma(5) * 2.5,
                extent: 0.5,
                scene_extent: 3.0,
            },
            LightSource::Hemisphere {
                radiance: Vec3::new(0.5, 0.7, 1.0),
            },
        ];
        // Points below, beside and above the lights, normals up and down.
        let p = Vec3x8::from_fn(8, |l| {
            Vec3::new(l as f32 * 0.3 - 1.0, (l % 3) as f32, 0.1 * l as f32)
        });
        let n = Vec3x8::from_fn(8, |l| {
            if l % 4 == 3 {
                Vec3::NEG_Y
            } else {
                Vec3::new(0.1 * l as f32, 1.0, 0.0).normalize()
            }
        });
        let origin = p + n * f32x8::splat(1e-4);
        let u = f32x8::from([0.0, 0.1, 0.25, 0.5, 0.6, 0.75, 0.9, 0.99]);
        let v = f32x8::from([0.3, 0.99, 0.0, 0.5, 0.12, 0.8, 0.45, 0.7]);
        for light in &lights {
            let s = light.sample_x8((p, origin, n), u, v).unwrap();
            let mut valid = 0;
            for l in 0..8 {
                let (u, v) = (u.as_array()[l], v.as_array()[l]);
                let one = scalar_sample(light, p.lane(l), origin.lane(l), n.lane(l), u, v);
                let via_sample = light.sample(p.lane(l), origin.lane(l), n.lane(l), u, v, 0);
                let bits = |s: &LightSample| {
                    let v = [s.direction, s.weight].map(|v| v.to_array().map(f32::to_bits));
                    (v, s.t_max.to_bits(), s.cos_surface.to_bits())
                };
                assert_eq!(
                    s.lane(l).as_ref().map(bits),
                    one.as_ref().map(bits),
                    "{light:?} lane {l}"
                );
                assert_eq!(
                    via_sample.as_ref().map(bits),
                    one.as_ref().map(bits),
                    "{light:?} lane {l}"
                );
                valid += one.is_some() as u32;
            }
            // The inputs reach both outcomes for every light.
            assert!(
                0 < valid && valid < 8,
                "{light:?}: {valid} of 8 lanes valid"
            );
        }
    }

    /// A mesh light's triangle pick gives every triangle a chance, however
    /// small its share of the area (down to 1e-15 of it among a hundred
    /// thousand others, far under the 2⁻²⁴ a 24-bit draw can tell apart),
    /// the first and last bits of its slots choose it, and its weight
    /// (area over probability) times its probability is its area: the
    /// estimate is unbiased whatever the rounding of the shares. The
    /// probabilities add up to one and stay within a slot of the shares.
    #[test]
    fn mesh_light_pick_weights_each_triangle_by_its_own_chance() {
        let mut areas = vec![1.0, 1e-15, 0.5, 3e-9, 1e-15];
        areas.extend((0..100_000).map(|i| 1e-6 * (1.0 + (i % 7) as f64)));
        areas.extend([2.0, 1e-15]);
        let pick = TrianglePick::by_area(&areas);
        let total: f64 = areas.iter().sum();
        let slot = 2f64.powi(-32);
        let (mut start, mut sum) = (0u64, 0.0);
        for (i, &area) in areas.iter().enumerate() {
            let p = pick.probability(i);
            assert!(p >= slot, "triangle {i} (area {area}) has probability {p}");
            let end = start + (p / slot) as u64;
            assert_eq!(pick.triangle(start as u32), i, "first slot of {i}");
            assert_eq!(pick.triangle((end - 1) as u32), i, "last slot of {i}");
            let weighted = f64::from(pick.area_over_probability[i]) * p;
            assert!(
                (weighted - area).abs() <= 1e-6 * area,
                "triangle {i}: weight × probability {weighted}, area {area}"
            );
            assert!(
                (p - area / total).abs() <= 2.0 * slot,
                "triangle {i}: probability {p}, area share {}",
                area / total
            );
            (start, sum) = (end, sum + p);
        }
        assert_eq!(start, 1 << 32, "the slots cover every pick");
        assert_eq!(sum, 1.0);
    }

    /// An emissive mesh is sampled by area: a triangle with probability
    /// area / total area (by the bits `pick`), then a point uniform on it
    /// (by `u`, `v`), weighted by Lₑ · area / probability · cos θ_light /
    /// d². On a stratified grid
    /// of (u, v, pick), each triangle gets its share of the samples, every
    /// point lies on the triangle it came from, the points' mean is that
    /// triangle's centroid, and each weight is the formula's.
    ///
    /// The estimator tests' renders check the same in the mean only, where
    /// a wrong point (say off the triangle) also makes the estimate noisy
    /// enough to hide a bias of a few percent inside their interval.
    #[test]
    fn mesh_lights_sample_points_uniformly_by_area() {
        // Corner a and edges to b and c, at height 1. The small one is
        // wound the other way: its geometric normal points away from p, and
        // the two-sided light must still shine toward p.
        let triangle = |a: Vec3, ab: Vec3, ac: Vec3| [a, a + ab, a + ac];
        let big = triangle(Vec3::new(-1.0, 1.0, -0.5), Vec3::X * 1.4, Vec3::Z);
        let small = triangle(Vec3::new(0.5, 1.0, 0.1), Vec3::Z * 0.2, Vec3::X * 0.35);
        let area = |t: &[Vec3; 3]| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
        let total = area(&big) + area(&small);
        let radiance = [Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 8.0)];
        let light = LightSource::Mesh {
            triangles: vec![big, small],
            radiance: radiance.to_vec(),
            pick: TrianglePick::by_area(&[area(&big) as f64, area(&small) as f64]),
            scene_extent: 1.0,
        };
        let (p, n) = (Vec3::new(0.1, 0.0, 0.05), Vec3::Y);
        let origin = offset_by(p, n, 1e-6);

        const K: usize = 24;
        let grid = |i: usize| (i as f32 + 0.5) / K as f32;
        let bits = |x: f32| (f64::from(x) * 2f64.powi(32)) as u32;
        let (mut count, mut sum) = ([0usize; 2], [Vec3::ZERO; 2]);
        for (i, j, k) in (0..K * K * K).map(|s| (s % K, s / K % K, s / (K * K))) {
            let s = light
                .sample(p, origin, n, grid(i), grid(j), bits(grid(k)))
                .expect("every point of the light sees p");
            let q = origin + s.direction * s.t_max;
            // The triangle it came from, told by its radiance.
            let t = usize::from(s.weight.z > 0.0);
            let [a, b, c] = [big, small][t];
            // On the triangle: in its plane (the end stops short of it by
            // far less than 1e-4) and inside its edges.
            assert!((q.y - 1.0).abs() < 1e-4, "{q} off the light's plane");
            let e = (b - a).cross(c - a);
            let (beta, gamma_) = ((q - a).cross(c - a).dot(e), (b - a).cross(q - a).dot(e));
            let (beta, gamma_) = (beta / e.length_squared(), gamma_ / e.length_squared());
            assert!(
                beta > -1e-4 && gamma_ > -1e-4 && beta + gamma_ < 1.0 + 1e-4,
                "{q} outside triangle {t}"
            );
            // Lₑ · A · cos θ_light / d², measured from p (to within the
            // ~1e-4 relative by which the ray's end stops short of q).
            let d = q - p;
            let cos_light = d.normalize().y;
            let expected = radiance[t] * (total * cos_light / d.length_squared());
            assert!(
                (s.weight - expected).abs().max_element() < 5e-4 * expected.max_element(),
                "weight {} vs {expected}",
                s.weight
            );
            assert!((s.cos_surface - cos_light).abs() < 1e-4);
            count[t] += 1;
            sum[t] += q;
        }
        let samples = (K * K * K) as f32;
        let share = count[0] as f32 / samples;
        assert!(
            (share - area(&big) / total).abs() <= 1.0 / K as f32,
            "big triangle drawn {share} of the time, area share {}",
            area(&big) / total
        );
        for (t, tri) in [big, small].iter().enumerate() {
            let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
            let mean = sum[t] / count[t] as f32;
            let size = (tri[1] - tri[0]).length().max((tri[2] - tri[0]).length());
            assert!(
                (mean - centroid).length() < 0.02 * size,
                "triangle {t}: mean point {mean}, centroid {centroid}"
            );
        }
    }

    /// A sphere light seen from outside is sampled uniformly in the cone it
    /// subtends: every direction reaches the sphere, every weight is
    /// Lₑ / pdf = Lₑ · 2π(1 − cos θmax), and the stratified mean of
    /// weight · cos is the closed-form irradiance π Lₑ sin²θmax when the
    /// sphere is straight above. From inside, directions are uniform over
    /// the sphere (weight Lₑ · 4π). A small, distant sphere keeps its solid
    /// angle (1 − cos θmax by its series, where 1 − √(1 − sin²θmax) rounds
    /// to zero in f32).
    #[test]
    fn sphere_lights_sample_the_cone_they_subtend() {
        let (n, radiance) = (Vec3::Y, 2.0f32);
        let sphere = |center: Vec3, radius: f32| LightSource::Sphere {
            center,
            radius,
            radiance: Vec3::splat(radiance),
        };
        const K: usize = 32;
        let grid = |i: usize| (i as f32 + 0.5) / K as f32;
        let samples = |light: &LightSource, p: Vec3, n: Vec3| -> Vec<LightSample> {
            let origin = offset_by(p, n, 1e-6);
            (0..K * K)
                .filter_map(|s| light.sample(p, origin, n, grid(s % K), grid(s / K), 0))
                .collect()
        };
        let two_pi = 2.0 * std::f32::consts::PI;
        // Where a shadow ray (origin o, o + d its end) first meets the
        // sphere, in units of d: just past 1, since it must stop short of
        // the near surface from outside and of the far one from inside.
        let meets = |o: Vec3, d: Vec3, center: Vec3, radius: f32| {
            let (o, d, c) = (o.as_dvec3(), d.as_dvec3(), center.as_dvec3());
            let (a, b) = (d.length_squared(), d.dot(o - c));
            let k = (o - c).length_squared() - (radius as f64).powi(2);
            let root = (b * b - a * k).sqrt();
            [(-b - root) / a, (-b + root) / a]
                .into_iter()
                .find(|&t| t > 0.0)
                .unwrap()
        };
        let assert_stops_short = |p: Vec3, n: Vec3, s: &LightSample, center, radius| {
            let t = meets(offset_by(p, n, 1e-6), s.direction * s.t_max, center, radius);
            assert!(
                t > 1.0 && t < 1.0 + 1e-4,
                "shadow ray meets the sphere at {t}"
            );
            // ... and it goes the way that was sampled (whose cosine it reports).
            let cos = s.direction.normalize().dot(n);
            assert!(
                (cos - s.cos_surface).abs() < 1e-4,
                "{cos} vs {}",
                s.cos_surface
            );
        };

        // Outside: centre 3 above p, radius 1, so sin²θmax = 1/9.
        let (center, radius, p) = (Vec3::new(0.0, 3.0, 0.0), 1.0, Vec3::ZERO);
        let drawn = samples(&sphere(center, radius), p, n);
        assert_eq!(drawn.len(), K * K, "every direction of the cone is above p");
        let solid_angle = two_pi * (1.0 - (8.0f32 / 9.0).sqrt());
        let mut irradiance = 0.0;
        for s in &drawn {
            assert_stops_short(p, n, s, center, radius);
            assert!((s.weight.x - radiance * solid_angle).abs() < 1e-5 * s.weight.x);
            irradiance += s.weight.x * s.cos_surface / (K * K) as f32;
        }
        let expected = std::f32::consts::PI * radiance / 9.0;
        assert!(
            (irradiance - expected).abs() < 1e-3 * expected,
            "irradiance {irradiance} vs {expected}"
        );

        // Inside, off centre: the whole sphere of directions, pdf 1/4π,
        // half of them above the surface; the irradiance inside a uniformly
        // glowing sphere is π Lₑ on any plane (here one tilted off the axes
        // the directions are drawn about).
        let (p_inside, n) = (center + Vec3::new(0.3, 0.0, 0.0), Vec3::new(0.0, 0.6, 0.8));
        let drawn = samples(&sphere(center, radius), p_inside, n);
        let half = (drawn.len() as f32 / (K * K) as f32 - 0.5).abs();
        assert!(half <= 1.0 / K as f32, "{} directions above", drawn.len());
        let mut irradiance = 0.0;
        for s in &drawn {
            assert_stops_short(p_inside, n, s, center, radius);
            assert!((s.weight.x - radiance * 2.0 * two_pi).abs() < 1e-5 * s.weight.x);
            irradiance += s.weight.x * s.cos_surface / (K * K) as f32;
        }
        let expected = std::f32::consts::PI * radiance;
        assert!(
            (irradiance - expected).abs() < 1e-2 * expected,
            "irradiance inside {irradiance} vs {expected}"
        );

        // Radius 1 at distance 1e4: sin²θmax = 1e-8, E = π Lₑ 1e-8.
        let drawn = samples(&sphere(Vec3::new(0.0, 1e4, 0.0), 1.0), p, Vec3::Y);
        assert_eq!(drawn.len(), K * K);
        for s in &drawn {
            let e = s.weight.x * s.cos_surface;
            let expected = std::f32::consts::PI * radiance * 1e-8;
            assert!((e - expected).abs() < 1e-3 * expected, "{e} vs {expected}");
        }
    }

    /// Shadow rays toward a rectangle light end far enough before it that
    /// the BVH culls the box of the light's own (flat) triangles instead
    /// of testing them — and they still reach everything in front of it.
    #[test]
    fn shadow_rays_clear_the_emitter_box() {
        use crate::bvh::{Accel, Bvh, TraversalStats};
        use crate::ray::{Rays, offset_by};
        // A room's floor (y = 0) and ceiling light (y = 1.49, facing
        // down), plus a small mesh in a corner, away from the rays (without
        // it nothing would be left beside the flat pieces, and the build
        // would not set them apart).
        let (center, dim_x, dim_y) = (
            Vec3::new(0.0, 1.49, 0.0),
            Vec3::new(0.8, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.6),
        );
        let corner = |a: f32, b: f32| center + a * dim_x + b * dim_y;
        let mut positions = vec![
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            corner(-0.5, -0.5),
            corner(0.5, -0.5),
            corner(0.5, 0.5),
            corner(-0.5, 0.5),
        ];
        let mut indices = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        for k in 0..20u32 {
            let o = Vec3::new(0.9, 0.05 + 0.01 * k as f32, 0.9);
            let i = positions.len() as u32;
            positions.extend([o, o + Vec3::X * 0.02, o + Vec3::Z * 0.02]);
            indices.push([i, i + 1, i + 2]);
        }

        let bvh = Bvh::from_triangle_soup(&positions, &indices, Accel::Sah);
        let light = LightSource::Rectangle {
            center,
            normal: Vec3::NEG_Y,
            dim_x,
            dim_y,
            radiance: Vec3::ONE,
            area: 0.48,
            q_err: gamma(5) * (center.abs() + 0.5 * dim_x.abs() + 0.5 * dim_y.abs()).max_element(),
            extent: (dim_x.abs() + dim_y.abs()).max_element(),
            scene_extent: 1.49,
        };
        // The shadow rays, and the same rays carried on to the light's
        // plane (which must hit the light).
        let (mut shadow, mut carried) = (Rays::default(), Rays::default());
        for i in 0..64 {
            let p = Vec3::new((i % 8) as f32 * 0.2 - 0.7, 0.0, (i / 8) as f32 * 0.2 - 0.7);
            let origin = offset_by(p, Vec3::Y, 1e-6);
            let (u, v) = (((i % 7) as f32 + 0.5) / 7.0, ((i % 5) as f32 + 0.5) / 5.0);
            let s = light.sample(p, origin, Vec3::Y, u, v, 0).unwrap();
            shadow.push(origin, s.direction, s.t_max);
            carried.push(origin, s.direction, 1.001);
        }
        let mut occluded = Vec::new();
        let mut stats = TraversalStats::default();
        bvh.occluded(&shadow, &mut occluded, &mut stats);
        assert!(occluded.iter().all(|&o| !o), "a shadow ray hit the light");
        assert_eq!(stats.primitives_tested, 0, "shadow rays tested triangles");
        bvh.occluded(&carried, &mut occluded, &mut stats);
        for (i, &o) in occluded.iter().enumerate() {
            assert!(o, "ray {i} carried on misses the light");
        }
        // A small occluder 1e-3 below the light's centre (a few times the
        // cap on the clearance) still casts its shadow.
        let k = positions.len() as u32;
        positions.extend([
            Vec3::new(-0.05, 1.489, -0.05),
            Vec3::new(0.05, 1.489, -0.05),
            Vec3::new(0.0, 1.489, 0.05),
        ]);
        indices.push([k, k + 1, k + 2]);
        let bvh = Bvh::from_triangle_soup(&positions, &indices, Accel::Sah);
        let p = Vec3::ZERO;
        let origin = offset_by(p, Vec3::Y, 1e-6);
        let s = light.sample(p, origin, Vec3::Y, 0.5, 0.5, 0).unwrap();
        let mut ray = Rays::default();
        ray.push(origin, s.direction, s.t_max);
        bvh.occluded(&ray, &mut occluded, &mut stats);
        assert!(
            occluded[0],
            "the occluder in front of the light casts no shadow"
        );
    }
}
