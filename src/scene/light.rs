//! Light sources, in world space, as the scene file defines them.

use std::sync::Arc;

use glam::Vec3;

use super::EnvironmentMap;
use crate::lanes::normalize_any_scale;

#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light; irradiance falls off as `intensity / d²`.
    Point { position: Vec3, intensity: Vec3 },
    /// Light from a single direction; `to_light` is a unit vector pointing at the light.
    Directional { to_light: Vec3, radiance: Vec3 },
    /// One-sided rectangle emitting `radiance` toward `normal`.
    /// Corners are `center ± dim_x/2 ± dim_y/2`.
    Area {
        center: Vec3,
        normal: Vec3,
        dim_x: Vec3,
        dim_y: Vec3,
        radiance: Vec3,
    },
    /// Uniform sky over the upper (+y) hemisphere; invisible to camera rays.
    Hemisphere { radiance: Vec3 },
    /// Radiance from every direction, from a latitude–longitude map
    /// (`-e`); seen by camera rays too, as in the CS184 renderer.
    Environment(Arc<EnvironmentMap>),
}

impl Light {
    /// Whether the light sends out anything: a colour of 0 0 0 (negative
    /// components are refused when loading) lights nothing.
    pub fn emits(&self) -> bool {
        let colour = match self {
            Light::Environment(map) => return map.emits(),
            Light::Point { intensity, .. } => *intensity,
            Light::Directional { radiance, .. }
            | Light::Area { radiance, .. }
            | Light::Hemisphere { radiance } => *radiance,
        };
        colour.max_element() > 0.0
    }

    pub fn kind_name(&self) -> &'static str {
        match self {
            Light::Point { .. } => "point",
            Light::Directional { .. } => "directional",
            Light::Area { .. } => "area",
            Light::Hemisphere { .. } => "hemisphere",
            Light::Environment(_) => "environment map",
        }
    }

    /// Area of an area light (0 for the others): the parallelogram
    /// |dim_x × dim_y|, which is |dim_x|·|dim_y| unless the node's transform
    /// shears the rectangle.
    pub fn area(&self) -> f32 {
        match self {
            Light::Area { dim_x, dim_y, .. } => dim_x.cross(*dim_y).as_dvec3().length() as f32,
            _ => 0.0,
        }
    }

    /// Unit normal of the emitting plane of an area light, on the side the
    /// light's `normal` points to (the two differ only under a shear).
    pub fn emitting_normal(&self) -> Option<Vec3> {
        match self {
            Light::Area {
                normal,
                dim_x,
                dim_y,
                ..
            } => {
                let n = normalize_any_scale(dim_x.cross(*dim_y)).unwrap_or(*normal);
                Some(if n.dot(*normal) < 0.0 { -n } else { n })
            }
            _ => None,
        }
    }

    /// The four corners of an area light in winding order.
    pub fn area_corners(&self) -> Option<[Vec3; 4]> {
        match self {
            Light::Area {
                center,
                dim_x,
                dim_y,
                ..
            } => {
                let (hx, hy) = (0.5 * *dim_x, 0.5 * *dim_y);
                Some([
                    *center - hx - hy,
                    *center + hx - hy,
                    *center + hx + hy,
                    *center - hx + hy,
                ])
            }
            _ => None,
        }
    }
}
