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

/// γₙ = nε / (1 − nε) with ε = 2⁻²⁴ (half an ULP of 1): the classic bound
/// on the relative error of `n` chained f32 operations (Higham; PBRT §3.9).
pub const fn gamma(n: u32) -> f32 {
    let e = n as f32 * (f32::EPSILON * 0.5);
    e / (1.0 - e)
}

/// Moves a surface point off the surface along the geometric normal `n`
/// (unit, pointing to the side the new ray leaves from) by `err`, a bound on
/// how far the computed point may lie on the wrong side of the surface *as
/// the intersection tests will see it*, then one more ULP per axis away
/// from the surface so that rounding the sum cannot undo the move.
///
/// The callers derive `err` from the arithmetic that produced the point and
/// from the extent of the primitive (the ray/triangle and ray/sphere tests
/// work in coordinates relative to the ray origin, so their rounding scales
/// with the distance to the primitive's far end); see `surface_point` in
/// `wavefront/shade.rs` and `integrator/lights.rs`. Because every term is
/// relative to the magnitudes involved, the offset is right at any scene
/// scale: about one ULP of the point for small primitives far from the
/// origin, and ~1e-6 of the primitive's size near it. (A fixed epsilon is
/// too big for tiny scenes and below the float spacing far from the
/// origin; a fixed count of ULPs, as in Wächter and Binder's method, is
/// hundreds of times larger than the error far from the origin and needs
/// an absolute floor near it. `tests/stress.rs` catches both.)
#[inline]
pub fn offset_by(p: Vec3, n: Vec3, err: f32) -> Vec3 {
    let moved = p + err * n;
    // One ULP further in the direction of n: ±1 on the bit pattern, which
    // moves away from zero for a positive step on a positive number, etc.
    let away = |x: f32, n: f32| -> f32 {
        if n == 0.0 || !x.is_finite() {
            return x;
        }
        let up = n > 0.0;
        if x == 0.0 {
            let tiny = f32::from_bits(1);
            return if up { tiny } else { -tiny };
        }
        let bits = x.to_bits();
        let bigger = (x > 0.0) == up;
        f32::from_bits(if bigger { bits + 1 } else { bits - 1 })
    };
    Vec3::new(away(moved.x, n.x), away(moved.y, n.y), away(moved.z, n.z))
}

/// [`offset_by`] for a point known to within a few ULPs of its own
/// coordinates, tested against primitives no larger than its distance
/// from the origin (`err` = γ₈·max|pᵢ|). The renderer's stages know more
/// about their points and call [`offset_by`] directly.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    offset_by(p, n, gamma(8) * p.abs().max_element())
}
