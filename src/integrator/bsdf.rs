//! Surfaces the integrator can shade, prepared from the scene's materials.
//!
//! Lambertian reflection and emission are rendered exactly. Material records
//! the integrator does not model yet fall back to a Lambertian surface of
//! similar colour, with one warning per kind of record.

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use crate::scene::{Material, NamedMaterial};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// f = albedo / π.
    Diffuse { albedo: Vec3 },
    /// Emits `radiance` (only toward its geometric normal when `one_sided`); reflects nothing.
    Emitter { radiance: Vec3, one_sided: bool },
}

impl Surface {
    /// The Lambertian BRDF value, f = albedo / π (zero for emitters).
    #[inline]
    pub fn f(&self) -> Vec3 {
        match self {
            Surface::Diffuse { albedo } => *albedo * FRAC_1_PI,
            Surface::Emitter { .. } => Vec3::ZERO,
        }
    }
}

/// One [`Surface`] per material, plus warnings for the fallbacks taken.
pub fn prepare(materials: &[NamedMaterial], warnings: &mut Vec<String>) -> Vec<Surface> {
    let mut warned: Vec<&str> = Vec::new();
    materials
        .iter()
        .map(|m| {
            let fallback = |albedo: Vec3, warned: &mut Vec<&str>, warnings: &mut Vec<String>| {
                let kind = m.material.kind_name();
                if !warned.contains(&kind) {
                    warned.push(kind);
                    warnings.push(format!(
                        "{kind} materials (first: {:?}) are not rendered yet; shading them as diffuse with albedo {albedo}",
                        m.name
                    ));
                }
                Surface::Diffuse { albedo }
            };
            match &m.material {
                Material::Diffuse { albedo } => Surface::Diffuse { albedo: *albedo },
                Material::Emission {
                    radiance,
                    one_sided,
                } => Surface::Emitter {
                    radiance: *radiance,
                    one_sided: *one_sided,
                },
                Material::Mirror { reflectance } => fallback(*reflectance, &mut warned, warnings),
                Material::Glass { reflectance, .. } => fallback(*reflectance, &mut warned, warnings),
                Material::Refraction { transmittance, .. } => {
                    fallback(*transmittance, &mut warned, warnings)
                }
                Material::Microfacet { .. } => fallback(Vec3::splat(0.5), &mut warned, warnings),
            }
        })
        .collect()
}
