//! The scene data model and its loaders.
//!
//! Loading produces a [`Scene`]: flat world-space geometry, a material table,
//! lights and a camera. Everything downstream (BVH, stages, film) reads this
//! and nothing else.

pub mod camera;
pub mod camera_file;
pub mod collada;
pub mod environment;
pub mod geometry;
pub mod light;
pub mod material;

pub use camera::{Camera, CameraView, Perspective};
pub use environment::EnvironmentMap;
pub use geometry::{Aabb, Geometry, Primitive, Spheres, Triangles};
pub use light::Light;
pub use material::{Material, NamedMaterial};

/// A loaded scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub geometry: Geometry,
    /// Material table; primitives refer to it by index.
    pub materials: Vec<NamedMaterial>,
    pub lights: Vec<Light>,
    pub camera: Camera,
    /// Non-fatal problems found while loading, one line each.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Puts a scene together. Area lights become geometry too (one-sided
    /// emissive rectangles, wound so their geometric normal is the light's
    /// normal), so camera rays see them and they cast shadows.
    pub fn assemble(
        mut geometry: Geometry,
        mut materials: Vec<NamedMaterial>,
        lights: Vec<Light>,
        camera: Camera,
        warnings: Vec<String>,
    ) -> Scene {
        for light in &lights {
            let (Some(corners), Some(normal), Light::Area { radiance, .. }) =
                (light.area_corners(), light.emitting_normal(), light)
            else {
                continue;
            };
            let normal = &normal;
            let index = materials.len() as u32;
            materials.push(NamedMaterial {
                name: format!("area light {index}"),
                material: Material::Emission {
                    radiance: *radiance,
                    one_sided: true,
                },
            });
            let tris = &mut geometry.triangles;
            let base = tris.positions.len() as u32;
            tris.positions.extend_from_slice(&corners);
            tris.normals.extend_from_slice(&[*normal; 4]);
            let along = (corners[1] - corners[0])
                .cross(corners[2] - corners[0])
                .dot(*normal)
                > 0.0;
            let quad: [[u32; 3]; 2] = if along {
                [[0, 1, 2], [0, 2, 3]]
            } else {
                [[0, 2, 1], [0, 3, 2]]
            };
            let had_texcoords = !tris.texcoords.is_empty();
            for q in quad {
                tris.indices.push(q.map(|i| i + base));
                tris.material.push(index);
                if had_texcoords {
                    tris.texcoords.push([glam::Vec2::ZERO; 3]);
                }
            }
        }
        Scene {
            geometry,
            materials,
            lights,
            camera,
            warnings,
        }
    }

    #[inline]
    pub fn material_of(&self, prim: u32) -> &Material {
        &self.materials[self.geometry.material(prim) as usize].material
    }
}
