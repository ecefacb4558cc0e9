//! Surface materials as typed records.
//!
//! The loader turns every material record of the scene dialect into one of
//! these variants. Which of them the integrator can render, and how the rest
//! fall back, is the integrator's business, not the loader's.

use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflector, `f = albedo / π`.
    Diffuse { albedo: Vec3 },
    /// Emitter of constant radiance; reflects nothing. Emissive meshes (CGL
    /// `emission`) emit from both faces; area-light rectangles only toward
    /// their geometric normal (`one_sided`).
    Emission { radiance: Vec3, one_sided: bool },
    /// Perfect specular reflector.
    Mirror { reflectance: Vec3 },
    /// Dielectric with reflection and transmission.
    Glass {
        reflectance: Vec3,
        transmittance: Vec3,
        roughness: f32,
        ior: f32,
    },
    /// Pure refraction (no reflection lobe).
    Refraction {
        transmittance: Vec3,
        roughness: f32,
        ior: f32,
    },
    /// Conductor microfacet (Beckmann `alpha`, complex IOR `eta + i k`).
    Microfacet { alpha: f32, eta: Vec3, k: Vec3 },
}

impl Material {
    /// The grey Lambertian used where a scene names no usable material.
    pub const DEFAULT: Material = Material::Diffuse {
        albedo: Vec3::splat(0.5),
    };

    pub fn kind_name(&self) -> &'static str {
        match self {
            Material::Diffuse { .. } => "diffuse",
            Material::Emission { .. } => "emission",
            Material::Mirror { .. } => "mirror",
            Material::Glass { .. } => "glass",
            Material::Refraction { .. } => "refraction",
            Material::Microfacet { .. } => "microfacet",
        }
    }

    /// Radiance emitted by a surface of this material (zero for non-emitters).
    pub fn emitted(&self) -> Vec3 {
        match self {
            Material::Emission { radiance, .. } => *radiance,
            _ => Vec3::ZERO,
        }
    }
}

/// A material with the name the scene gave it.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedMaterial {
    pub name: String,
    pub material: Material,
}
