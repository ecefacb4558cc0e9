//! The scene data model and its loaders.
//!
//! Loading produces a [`Scene`]: flat world-space geometry, a material table,
//! lights and a camera. Everything downstream (BVH, stages, film) reads this
//! and nothing else.

pub mod camera;
pub mod collada;
pub mod geometry;
pub mod light;
pub mod material;

pub use camera::{Camera, CameraView, Perspective};
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
    #[inline]
    pub fn material_of(&self, prim: u32) -> &Material {
        &self.materials[self.geometry.material(prim) as usize].material
    }
}
