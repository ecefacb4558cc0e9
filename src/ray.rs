//! Rays and hit records as structure-of-arrays batches.
//!
//! Every stage of the wavefront reads and writes whole batches: one `Vec<f32>`
//! per component keeps the lanes of a SIMD register filled from contiguous
//! memory and lets a stage touch only the components it needs.

use glam::Vec3;

/// Sentinel primitive id meaning "no hit".
pub const NO_HIT: u32 = u32::MAX;

/// A batch of rays, one array per component.
///
/// A ray is `origin + t * direction` for `t` in `[0, t_max]`; callers offset
/// origins away from surfaces themselves (see [`offset_origin`]),
/// so there is no `t_min`. Directions need not be normalised.
#[derive(Clone, Debug, Default)]
pub struct Rays {
    pub org_x: Vec<f32>,
    pub org_y: Vec<f32>,
    pub org_z: Vec<f32>,
    pub dir_x: Vec<f32>,
    pub dir_y: Vec<f32>,
    pub dir_z: Vec<f32>,
    pub t_max: Vec<f32>,
}

impl Rays {
    pub fn with_capacity(n: usize) -> Self {
        Rays {
            org_x: Vec::with_capacity(n),
            org_y: Vec::with_capacity(n),
            org_z: Vec::with_capacity(n),
            dir_x: Vec::with_capacity(n),
            dir_y: Vec::with_capacity(n),
            dir_z: Vec::with_capacity(n),
            t_max: Vec::with_capacity(n),
        }
    }

    pub fn len(&self) -> usize {
        self.t_max.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t_max.is_empty()
    }

    pub fn clear(&mut self) {
        self.truncate(0);
    }

    /// Copies ray `from` over ray `to`.
    #[inline]
    pub fn copy_within(&mut self, from: usize, to: usize) {
        for component in self.components_mut() {
            component[to] = component[from];
        }
    }

    /// Keeps the first `n` rays.
    pub fn truncate(&mut self, n: usize) {
        for component in self.components_mut() {
            component.truncate(n);
        }
    }

    fn components_mut(&mut self) -> [&mut Vec<f32>; 7] {
        [
            &mut self.org_x,
            &mut self.org_y,
            &mut self.org_z,
            &mut self.dir_x,
            &mut self.dir_y,
            &mut self.dir_z,
            &mut self.t_max,
        ]
    }

    pub fn push(&mut self, origin: Vec3, direction: Vec3, t_max: f32) {
        self.org_x.push(origin.x);
        self.org_y.push(origin.y);
        self.org_z.push(origin.z);
        self.dir_x.push(direction.x);
        self.dir_y.push(direction.y);
        self.dir_z.push(direction.z);
        self.t_max.push(t_max);
    }

    #[inline]
    pub fn origin(&self, i: usize) -> Vec3 {
        Vec3::new(self.org_x[i], self.org_y[i], self.org_z[i])
    }

    #[inline]
    pub fn direction(&self, i: usize) -> Vec3 {
        Vec3::new(self.dir_x[i], self.dir_y[i], self.dir_z[i])
    }
}

/// Closest-hit results for a batch of rays, index-aligned with [`Rays`].
///
/// `prim` is [`NO_HIT`] for a miss; otherwise it is a primitive id in the
/// numbering of [`crate::scene::Geometry`] (triangles first, then spheres).
/// `u`, `v` are the barycentric coordinates of the hit on a triangle
/// (weights of vertices 1 and 2); unused for spheres.
#[derive(Clone, Debug, Default)]
pub struct Hits {
    pub t: Vec<f32>,
    pub prim: Vec<u32>,
    pub u: Vec<f32>,
    pub v: Vec<f32>,
}

impl Hits {
    /// Resets to `n` misses.
    pub fn reset(&mut self, n: usize) {
        self.t.clear();
        self.t.resize(n, f32::INFINITY);
        self.prim.clear();
        self.prim.resize(n, NO_HIT);
        self.u.clear();
        self.u.resize(n, 0.0);
        self.v.clear();
        self.v.resize(n, 0.0);
    }

    pub fn len(&self) -> usize {
        self.prim.len()
    }

    pub fn is_empty(&self) -> bool {
        self.prim.is_empty()
    }

    #[inline]
    pub fn is_hit(&self, i: usize) -> bool {
        self.prim[i] != NO_HIT
    }
}

/// Moves a surface point off the surface along the geometric normal `n`
/// (pointing to the side the new ray leaves from), far enough that a ray
/// starting there cannot hit the surface it left, at any scene scale.
///
/// The offset is a fixed number of ULPs of each coordinate (so it scales
/// with the magnitude of the point, which bounds the rounding error of a
/// computed hit point), with a small absolute floor near the origin where
/// ULPs become denormal. This is the integer-offset method of Wächter and
/// Binder ("A Fast and Robust Method for Avoiding Self-Intersection", Ray
/// Tracing Gems, 2019).
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let offset_axis = |p: f32, n: f32| -> f32 {
        let of_i = (INT_SCALE * n) as i32;
        let bits = p.to_bits() as i32;
        let moved = f32::from_bits((bits + if p < 0.0 { -of_i } else { of_i }) as u32);
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            moved
        }
    };
    Vec3::new(
        offset_axis(p.x, n.x),
        offset_axis(p.y, n.y),
        offset_axis(p.z, n.z),
    )
}
