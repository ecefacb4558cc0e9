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
            // `source`: the record's colour the albedo is, if any. One
            // warning per kind; each material keeps its own albedo.
            let fallback = |albedo: Vec3,
                            source: Option<&str>,
                            warned: &mut Vec<&str>,
                            warnings: &mut Vec<String>| {
                let kind = m.material.kind_name();
                if !warned.contains(&kind) {
                    warned.push(kind);
                    let how = match source {
                        Some(source) => format!(
                            "each as diffuse with its {source} as albedo ({:?}: {albedo})",
                            m.name
                        ),
                        None => format!("them as diffuse with albedo {albedo}"),
                    };
                    warnings.push(format!(
                        "{kind} materials (first: {:?}) are not rendered yet; shading {how}",
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
                Material::Mirror { reflectance } | Material::Glass { reflectance, .. } => {
                    fallback(*reflectance, Some("reflectance"), &mut warned, warnings)
                }
                Material::Refraction { transmittance, .. } => {
                    fallback(*transmittance, Some("transmittance"), &mut warned, warnings)
                }
                Material::Microfacet { .. } => {
                    fallback(Vec3::splat(0.5), None, &mut warned, warnings)
                }
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records not rendered yet fall back to diffuse surfaces, each with
    /// its own colour, under one warning per kind that names the first.
    #[test]
    fn fallbacks_keep_each_material_s_colour_under_one_warning_per_kind() {
        let named = |name: &str, material| NamedMaterial {
            name: name.into(),
            material,
        };
        let materials = [
            named(
                "bright",
                Material::Mirror {
                    reflectance: Vec3::ONE,
                },
            ),
            named(
                "dim",
                Material::Mirror {
                    reflectance: Vec3::splat(0.2),
                },
            ),
            named(
                "clear",
                Material::Refraction {
                    transmittance: Vec3::new(0.9, 0.8, 0.7),
                    roughness: 0.0,
                    ior: 1.5,
                },
            ),
            named("wall", Material::DEFAULT),
        ];
        let mut warnings = Vec::new();
        let surfaces = prepare(&materials, &mut warnings);
        let albedo = |s: &Surface| match s {
            Surface::Diffuse { albedo } => *albedo,
            Surface::Emitter { .. } => panic!("{s:?}"),
        };
        let albedos: Vec<Vec3> = surfaces.iter().map(albedo).collect();
        assert_eq!(
            albedos,
            [
                Vec3::ONE,
                Vec3::splat(0.2),
                Vec3::new(0.9, 0.8, 0.7),
                Vec3::splat(0.5)
            ]
        );
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings[0].starts_with("mirror materials (first: \"bright\")"));
        assert!(warnings[0].contains("each as diffuse with its reflectance as albedo"));
        assert!(warnings[1].contains("with its transmittance as albedo"));
    }
}
