//! Rays and hit records as structure-of-arrays batches.
//!
//! Every stage of the wavefront reads and writes whole batches: one `Vec<f32>`
//! per component keeps the lanes of a SIMD register filled from contiguous
//! memory and lets a stage touch only the components it needs.

use glam::Vec3;
use wide::{f32x8, i32x8};

use crate::lanes::{self, LANES, Vec3x8};

/// Sentinel primitive id meaning "no hit".
pub const NO_HIT: u32 = u32::MAX;

/// A batch of rays, one array per component.
///
/// A ray is `origin + t * direction` for `t` in `[0, t_max]`; callers offset
/// origins away from surfaces themselves (see [`offset_from_surface`]),
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

    #[inline(always)]
    pub(crate) fn components_mut(&mut self) -> [&mut Vec<f32>; 7] {
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

    #[inline]
    pub fn push(&mut self, origin: Vec3, direction: Vec3, t_max: f32) {
        self.org_x.push(origin.x);
        self.org_y.push(origin.y);
        self.org_z.push(origin.z);
        self.dir_x.push(direction.x);
        self.dir_y.push(direction.y);
        self.dir_z.push(direction.z);
        self.t_max.push(t_max);
    }

    /// Appends the first `n` of eight rays given component by component
    /// (origin x, y, z, direction x, y, z, `t_max`; one array each).
    ///
    /// This and [`extend_lanes`](Self::extend_lanes) run once per eight
    /// rays in the stages' inner loops; left to the optimiser's judgement
    /// (`#[inline]`), they were compiled out of line after unrelated
    /// changes elsewhere in the crate (a 2% slower render, PERF.md).
    #[inline(always)]
    pub fn extend_arrays(&mut self, n: usize, components: &[[f32; LANES]; 7]) {
        for (component, values) in self.components_mut().into_iter().zip(components) {
            lanes::extend(component, values, n);
        }
    }

    /// Appends the first `n` of eight rays held lane-wise.
    #[inline(always)]
    pub fn extend_lanes(&mut self, n: usize, origin: Vec3x8, direction: Vec3x8, t_max: f32x8) {
        let (o, d) = (origin, direction);
        // Written out, not `[…].map(f32x8::to_array)`: the optimiser has
        // compiled such a `map` into a call (`core::array::try_map`).
        let lanes = [
            o.x.to_array(),
            o.y.to_array(),
            o.z.to_array(),
            d.x.to_array(),
            d.y.to_array(),
            d.z.to_array(),
            t_max.to_array(),
        ];
        self.extend_arrays(n, &lanes);
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
    offset_by_x8(Vec3x8::splat(p), Vec3x8::splat(n), f32x8::splat(err)).lane(0)
}

/// [`offset_by`] for eight points at once.
#[inline(always)]
pub fn offset_by_x8(p: Vec3x8, n: Vec3x8, err: f32x8) -> Vec3x8 {
    let moved = p + n * err;
    // One ULP further in the direction of n: ±1 on the bit pattern, which
    // moves away from zero for a positive step on a positive number, etc.
    // Zero steps to the smallest subnormal of the step's sign; a zero or
    // NaN normal component, or a non-finite coordinate, stays as it is.
    let away = |x: f32x8, n: f32x8| -> f32x8 {
        let up = n.simd_gt(f32x8::ZERO);
        let tiny = lanes::from_bits(i32x8::ONE) ^ (!up & f32x8::splat(-0.0));
        // Bigger magnitude when x and the step have the same sign:
        // all-ones masks are −1, so the step is (mask & 2) − 1 = ±1.
        let bigger = lanes::to_bits(!(x.simd_gt(f32x8::ZERO) ^ up));
        let stepped = lanes::from_bits(lanes::to_bits(x) + (bigger & i32x8::splat(2)) - i32x8::ONE);
        let keep = n.simd_eq(f32x8::ZERO) | !x.is_finite();
        keep.select(x, x.simd_eq(f32x8::ZERO).select(tiny, stepped))
    };
    Vec3x8::new(away(moved.x, n.x), away(moved.y, n.y), away(moved.z, n.z))
}

/// [`offset_by`] for a point `p` on a primitive, known to within a few
/// ULPs of its own coordinates: `reach` is the largest coordinate
/// difference between `p` and the primitive's farthest point (for a
/// triangle, [`surface_reach`] of its vertices), and `err` =
/// γ₈·(max|pᵢ| + reach). The reach matters: a point near the middle of a
/// large floor needs an offset set by the floor's size, not by its own
/// coordinates. For outside tools that trace batches; the renderer's
/// stages know more about their points and call [`offset_by`] directly.
#[inline]
pub fn offset_from_surface(p: Vec3, n: Vec3, reach: f32) -> Vec3 {
    offset_by(p, n, gamma(8) * (p.abs().max_element() + reach))
}

/// The largest coordinate difference between `p` and any of `corners`
/// (max over corners v of max|vᵢ − pᵢ|): the `reach` of
/// [`offset_from_surface`] for a point on a polygon with those corners.
pub fn surface_reach(p: Vec3, corners: &[Vec3]) -> f32 {
    corners
        .iter()
        .map(|&v| (v - p).abs().max_element())
        .fold(0.0, f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-coordinate rule of [`offset_by_x8`], written out with
    /// scalar branches: the specification the lane form must meet.
    fn step_away(x: f32, n: f32) -> f32 {
        if n == 0.0 || n.is_nan() || !x.is_finite() {
            return x;
        }
        let up = n > 0.0;
        if x == 0.0 {
            let tiny = f32::from_bits(1);
            return if up { tiny } else { -tiny };
        }
        let bits = x.to_bits();
        f32::from_bits(if (x > 0.0) == up { bits + 1 } else { bits - 1 })
    }

    /// Bit pattern, with every NaN the same (NaN payloads and signs depend
    /// on the order of operations).
    fn same_bits(x: f32) -> u32 {
        if x.is_nan() { u32::MAX } else { x.to_bits() }
    }

    #[test]
    fn offset_moves_one_more_ulp_away_in_every_lane() {
        let xs = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f32::from_bits(1),
            -f32::MIN_POSITIVE,
            1e5,
            -3.5e-3,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
        ];
        let ns = [0.0, -0.0, 0.6, -0.8, 1.0, -1.0, f32::NAN];
        for &err in &[0.0, 1e-6, 0.25] {
            for (k, &x) in xs.iter().enumerate() {
                // Eight different normals per call, so a lane mix-up shows.
                let n = std::array::from_fn::<f32, 8, _>(|l| ns[(k + l) % ns.len()]);
                let p = Vec3x8::splat(Vec3::new(x, -x, x));
                let nv = Vec3x8::new(n.into(), f32x8::from(n) * f32x8::splat(-1.0), n.into());
                let got = offset_by_x8(p, nv, f32x8::splat(err));
                for (lane, &nl) in n.iter().enumerate() {
                    let want = [x + err * nl, -x + err * -nl, x + err * nl]
                        .into_iter()
                        .zip([nl, -nl, nl])
                        .map(|(m, n)| same_bits(step_away(m, n)));
                    let got = got.lane(lane).to_array().map(same_bits);
                    assert!(
                        want.eq(got),
                        "x {x}, n {nl}, err {err}: lane {lane} got {got:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn offset_point_is_strictly_on_the_normal_side() {
        // Any scale: the moved point is beyond p along n by at least err.
        for &s in &[1e-6f32, 1.0, 1e5, 1e7] {
            let p = Vec3::new(0.3 * s, -0.7 * s, 0.1 * s);
            let n = Vec3::new(0.48, 0.6, -0.64);
            let q = offset_by(p, n, gamma(8) * s);
            assert!((q - p).dot(n) > 0.0, "scale {s}");
        }
    }

    #[test]
    fn surface_reach_is_the_largest_coordinate_difference_to_a_corner() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let corners = [Vec3::new(0.5, 4.0, 3.0), Vec3::new(1.0, 2.0, -1.0)];
        assert_eq!(surface_reach(p, &corners), 4.0);
        assert_eq!(surface_reach(p, &corners[..1]), 2.0);
        assert_eq!(surface_reach(p, &[]), 0.0);
    }

    /// The offset of a point on a triangle, for outside tools: the moved
    /// point lies strictly on the normal's side of the triangle's exact
    /// (f64) plane, and no farther from the point than twice the bound
    /// γ₈·(|p|∞ + reach) it is built from, at every scale and 1e5 from
    /// the origin (a tight offset keeps contact shadows).
    #[test]
    fn offset_from_surface_clears_the_plane_by_little() {
        let unit = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.1, -0.2),
            Vec3::new(0.3, 0.9, 0.4),
        ];
        for &(s, t) in &[
            (1e-6f32, Vec3::ZERO),
            (1.0, Vec3::ZERO),
            (1e4, Vec3::ZERO),
            (1.0, Vec3::new(1e5, -1e5, 3e4)),
        ] {
            let [a, b, c] = unit.map(|v| s * v + t);
            let n = (b - a).cross(c - a).normalize();
            let (ad, bd, cd) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
            let nd = (bd - ad).cross(cd - ad);
            for (u, v) in [(0.2f32, 0.3f32), (0.6, 0.35), (0.01, 0.01), (0.0, 0.0)] {
                let p = a + u * (b - a) + v * (c - a);
                let reach = surface_reach(p, &[a, b, c]);
                let bound = gamma(8) * (p.abs().max_element() + reach);
                for side in [n, -n] {
                    let q = offset_from_surface(p, side, reach);
                    let height = (q.as_dvec3() - ad).dot(nd) * side.as_dvec3().dot(nd).signum();
                    assert!(height > 0.0, "scale {s}, at {t}: ({u}, {v}) not cleared");
                    let moved = (q - p).abs().max_element();
                    assert!(
                        moved <= 2.0 * bound,
                        "scale {s}, at {t}: ({u}, {v}) moved {moved:e}, bound {bound:e}"
                    );
                }
            }
        }
    }
}
