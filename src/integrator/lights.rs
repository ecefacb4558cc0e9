//! Light sampling for next-event estimation.
//!
//! Every emitter becomes a [`LightSource`] that can draw a point or
//! direction as seen from a shading point and report the incident radiance
//! divided by the solid-angle pdf of that choice. Emissive meshes are one
//! source per scene, their triangles chosen in proportion to area.

use glam::Vec3;

use super::bsdf::Surface;
use crate::ray::{gamma, offset_by};
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
    /// Two-sided emissive triangles, sampled by area.
    Mesh {
        /// Vertex positions per triangle.
        triangles: Vec<[Vec3; 3]>,
        radiance: Vec<Vec3>,
        /// Cumulative area, normalised to end at 1.
        cdf: Vec<f32>,
        total_area: f32,
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

    /// Whether [`sample`](Self::sample) uses its third random number `w`
    /// (to pick a triangle); delta lights use none of them.
    pub fn uses_w(&self) -> bool {
        matches!(self, LightSource::Mesh { .. })
    }

    /// Draws a connection from surface point `p` (normal `n`) with random
    /// numbers `(u, v)` and, for meshes, `w` to pick a triangle. The weight
    /// and cosine are measured from `p`; the shadow ray starts at `origin`,
    /// `p` moved off its surface. `None` when the light cannot reach `p`.
    ///
    /// Inlined into the shading loop: called out of line, its vector
    /// arguments went through memory and the loads stalled on the caller's
    /// narrower stores (store-to-load forwarding failed).
    #[inline(always)]
    pub fn sample(
        &self,
        p: Vec3,
        origin: Vec3,
        n: Vec3,
        u: f32,
        v: f32,
        w: f32,
    ) -> Option<LightSample> {
        match self {
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
            } => {
                let q = *center + (u - 0.5) * *dim_x + (v - 0.5) * *dim_y;
                // One-sided: light leaves toward `normal` only.
                connect(
                    p,
                    origin,
                    n,
                    (q, *q_err, *extent),
                    *normal,
                    *area,
                    *radiance,
                )
            }
            LightSource::Hemisphere { radiance } => {
                // Cosine-weighted about the surface normal; only upward directions see the sky.
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
            LightSource::Sphere {
                center,
                radius,
                radiance,
            } => sample_sphere(p, origin, n, *center, *radius, *radiance, u, v),
            LightSource::Mesh {
                triangles,
                radiance,
                cdf,
                total_area,
            } => {
                let i = cdf.partition_point(|&c| c <= w).min(triangles.len() - 1);
                let [a, b, c] = triangles[i];
                // Uniform point on the triangle (square-root warp).
                let su = u.sqrt();
                let q = a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v);
                let q_err = gamma(7) * a.abs().max(b.abs()).max(c.abs()).max_element();
                let extent = (a - q).abs().max((b - q).abs()).max((c - q).abs());
                // Two-sided: the normal that faces p.
                let ng = (b - a).cross(c - a).normalize_or_zero();
                let facing = if ng.dot(p - q) >= 0.0 { ng } else { -ng };
                connect(
                    p,
                    origin,
                    n,
                    (q, q_err, extent.max_element()),
                    facing,
                    *total_area,
                    radiance[i],
                )
            }
        }
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
#[inline(always)]
fn connect(
    p: Vec3,
    origin: Vec3,
    n: Vec3,
    (q, q_err, extent): (Vec3, f32, f32),
    n_light: Vec3,
    area: f32,
    radiance: Vec3,
) -> Option<LightSample> {
    let d = q - p;
    let dist2 = d.length_squared();
    let inv_dist = dist2.sqrt().recip();
    let cos_light = -n_light.dot(d) * inv_dist;
    let cos_surface = n.dot(d) * inv_dist;
    if !(cos_light > 0.0 && cos_surface > 0.0) {
        return None;
    }
    // End the shadow ray just in front of the emitter so it cannot hit it:
    // beyond q's own error, and beyond the rounding of the ray/triangle
    // test from `origin`, ~γ₈ times the distance to the emitter's far corner.
    let reach = (q - origin).abs().max_element() + extent;
    let end = offset_by(q, n_light, q_err + gamma(8) * reach);
    Some(LightSample {
        direction: end - origin,
        t_max: 1.0,
        weight: radiance * (area * cos_light * inv_dist * inv_dist),
        cos_surface,
    })
}

/// Every light source of a scene.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub sources: Vec<LightSource>,
    /// Summed radiance of hemisphere lights, seen by rays that escape upward.
    pub sky: Vec3,
}

impl LightSet {
    pub fn new(scene: &Scene, surfaces: &[Surface]) -> LightSet {
        let mut set = LightSet::default();
        for light in &scene.lights {
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
                },
                Light::Hemisphere { radiance } => {
                    set.sky += radiance;
                    LightSource::Hemisphere { radiance }
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
        let (mut triangles, mut radiance, mut cdf) = (Vec::new(), Vec::new(), Vec::new());
        let mut total = 0.0f64;
        for t in 0..tris.len() {
            if let Surface::Emitter {
                radiance: le,
                one_sided: false,
            } = surfaces[tris.material[t] as usize]
            {
                let area = 0.5 * tris.geometric_normal(t).length() as f64;
                if area > 0.0 && le.max_element() > 0.0 {
                    total += area;
                    triangles.push(tris.vertices(t));
                    radiance.push(le);
                    cdf.push(total);
                }
            }
        }
        if !triangles.is_empty() {
            set.sources.push(LightSource::Mesh {
                triangles,
                radiance,
                cdf: cdf.iter().map(|&c| (c / total) as f32).collect(),
                total_area: total as f32,
            });
        }
        set
    }

    pub fn is_empty(&self) -> bool {
        self.sources.is_empty()
    }
}
