//! Stage 4: shadow tests. Shadow rays from light sampling ask only "is
//! anything in the way" (any-hit, early exit); probe rays from hemisphere
//! sampling need the closest hit to know what emitter they found.

use glam::Vec3;

use crate::bvh::{Bvh, TraversalStats};
use crate::integrator::bsdf::Surface;
use crate::integrator::lights::LightSet;
use crate::ray::Hits;
use crate::scene::Geometry;

use super::paths::{Paths, ShadowRays};

/// Adds the weight of every unoccluded shadow ray to its path.
pub fn resolve_shadow_rays(
    bvh: &Bvh,
    shadow: &ShadowRays,
    occluded: &mut Vec<bool>,
    paths: &mut Paths,
    stats: &mut TraversalStats,
) {
    bvh.occluded(&shadow.rays, occluded, stats);
    for (k, &blocked) in occluded.iter().enumerate() {
        if !blocked {
            paths.radiance[shadow.path[k] as usize] += shadow.weight[k];
        }
    }
}

/// Adds, for every probe ray, its weight times the radiance emitted toward
/// it by what it hits (or from beyond the scene, if it escapes).
#[allow(clippy::too_many_arguments)]
pub fn resolve_probe_rays(
    bvh: &Bvh,
    probes: &ShadowRays,
    hits: &mut Hits,
    geometry: &Geometry,
    surfaces: &[Surface],
    lights: &LightSet,
    paths: &mut Paths,
    stats: &mut TraversalStats,
) {
    bvh.intersect(&probes.rays, hits, stats, None);
    for k in 0..probes.len() {
        let d = probes.rays.direction(k);
        let emitted = if !hits.is_hit(k) {
            let beyond = lights.environment.as_ref();
            let map = beyond.map_or(Vec3::ZERO, |m| m.escaping(d, f32::INFINITY, 1));
            lights.sky_toward(d) + map
        } else {
            let prim = hits.prim[k];
            match surfaces[geometry.material(prim) as usize] {
                Surface::Emitter {
                    radiance,
                    one_sided,
                } => {
                    let facing = match geometry.primitive(prim) {
                        crate::scene::Primitive::Triangle(t) => {
                            geometry.triangles.geometric_normal(t).dot(d) < 0.0
                        }
                        crate::scene::Primitive::Sphere(_) => true,
                    };
                    if !one_sided || facing {
                        radiance
                    } else {
                        Vec3::ZERO
                    }
                }
                Surface::Diffuse { .. } => Vec3::ZERO,
            }
        };
        paths.radiance[probes.path[k] as usize] += probes.weight[k] * emitted;
    }
}
