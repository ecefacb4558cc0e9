//! World-space geometry in flat arrays: the form the BVH and the stages read.
//!
//! Primitive ids are global: triangles are numbered `0..triangle_count()`,
//! spheres follow them. Keeping one numbering lets a single BVH and a single
//! hit record cover both kinds without a `dyn` primitive.

use glam::{Vec2, Vec3};

use crate::lanes::normalize_any_scale;

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Largest coordinate magnitude of the box's corners (0 when empty):
    /// how far from the origin the scene reaches, which bounds rounding.
    pub fn max_abs(&self) -> f32 {
        if self.is_empty() {
            0.0
        } else {
            self.min.abs().max(self.max.abs()).max_element()
        }
    }

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }

    /// Surface area (0 for an empty box).
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.diagonal();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// Indexed triangle mesh of the whole scene, in world space.
#[derive(Clone, Debug, Default)]
pub struct Triangles {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Smooth shading normal per vertex (area-weighted, unit length).
    pub normals: Vec<Vec3>,
    /// Three vertex indices per triangle.
    pub indices: Vec<[u32; 3]>,
    /// Material id per triangle.
    pub material: Vec<u32>,
    /// Texture coordinates per triangle corner; empty when the scene has none.
    pub texcoords: Vec<[Vec2; 3]>,
}

impl Triangles {
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    #[inline]
    pub fn vertices(&self, tri: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[tri];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    pub fn bounds(&self, tri: usize) -> Aabb {
        let [a, b, c] = self.vertices(tri);
        Aabb {
            min: a.min(b).min(c),
            max: a.max(b).max(c),
        }
    }

    /// Unnormalised geometric normal `(b - a) × (c - a)`; its length is twice the area.
    #[inline]
    pub fn geometric_normal(&self, tri: usize) -> Vec3 {
        let [a, b, c] = self.vertices(tri);
        (b - a).cross(c - a)
    }

    /// Interpolated shading normal at barycentrics `(u, v)` (weights of vertices 1 and 2).
    #[inline]
    pub fn shading_normal(&self, tri: usize, u: f32, v: f32) -> Vec3 {
        let [a, b, c] = self.indices[tri];
        let n = (1.0 - u - v) * self.normals[a as usize]
            + u * self.normals[b as usize]
            + v * self.normals[c as usize];
        // The fallback is computed only when needed (degenerate normals).
        normalize_any_scale(n)
            .or_else(|| normalize_any_scale(self.geometric_normal(tri)))
            .unwrap_or(Vec3::Y)
    }
}

/// Spheres as structure of arrays.
#[derive(Clone, Debug, Default)]
pub struct Spheres {
    pub center: Vec<Vec3>,
    pub radius: Vec<f32>,
    pub material: Vec<u32>,
}

impl Spheres {
    pub fn len(&self) -> usize {
        self.radius.len()
    }

    pub fn is_empty(&self) -> bool {
        self.radius.is_empty()
    }

    /// Conservative bounds: `center ± radius` rounded outward, so a sphere
    /// smaller than the float spacing at its centre still gets a box that
    /// contains it (rounding to nearest would collapse the box to a point).
    pub fn bounds(&self, i: usize) -> Aabb {
        let r = Vec3::splat(self.radius[i]);
        let (lo, hi) = (self.center[i] - r, self.center[i] + r);
        Aabb {
            min: Vec3::new(lo.x.next_down(), lo.y.next_down(), lo.z.next_down()),
            max: Vec3::new(hi.x.next_up(), hi.y.next_up(), hi.z.next_up()),
        }
    }
}

/// All intersectable primitives of a scene.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    pub triangles: Triangles,
    pub spheres: Spheres,
}

/// What a global primitive id refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primitive {
    Triangle(usize),
    Sphere(usize),
}

impl Geometry {
    pub fn primitive_count(&self) -> usize {
        self.triangles.len() + self.spheres.len()
    }

    #[inline]
    pub fn primitive(&self, id: u32) -> Primitive {
        let id = id as usize;
        let t = self.triangles.len();
        if id < t {
            Primitive::Triangle(id)
        } else {
            Primitive::Sphere(id - t)
        }
    }

    pub fn primitive_bounds(&self, id: u32) -> Aabb {
        match self.primitive(id) {
            Primitive::Triangle(i) => self.triangles.bounds(i),
            Primitive::Sphere(i) => self.spheres.bounds(i),
        }
    }

    pub fn material(&self, id: u32) -> u32 {
        match self.primitive(id) {
            Primitive::Triangle(i) => self.triangles.material[i],
            Primitive::Sphere(i) => self.spheres.material[i],
        }
    }

    /// Bounds of all triangle vertices and spheres.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for &p in &self.triangles.positions {
            b.grow(p);
        }
        for i in 0..self.spheres.len() {
            b = b.union(&self.spheres.bounds(i));
        }
        b
    }
}
