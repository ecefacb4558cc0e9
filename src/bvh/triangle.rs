//! Watertight ray/triangle intersection, [`TRI_WIDTH`] triangles against
//! one ray or one triangle against [`WIDTH`] rays at a time.
//!
//! This is the algorithm of Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection" (JCGT 2013). The ray is turned into the +z axis of a sheared
//! coordinate system (per-ray constants, computed for eight rays at once by
//! [`RayTriLanes`] in the batch cull),
//! which reduces the inside test to the signs of three 2D edge functions
//!
//! ```text
//! U = Cx·By − Cy·Bx,   V = Ax·Cy − Ay·Cx,   W = Bx·Ay − By·Ax
//! ```
//!
//! of the transformed vertices. An edge shared by two triangles produces
//! the same value with opposite sign in both (floating-point subtraction is
//! antisymmetric and both evaluate the same products), so a ray can never
//! slip through the crack between them: at least one of the two sees all
//! three signs agree. When an edge function rounds to exactly zero, it is
//! recomputed in double precision, where the products are exact.
//!
//! No fused multiply-add may be used in the edge functions: `fma(a, b, −cd)`
//! is not the negation of `fma(c, d, −ab)`, which would break the symmetry.
//! Rust never contracts `a * b - c * d` on its own, so the plain operators
//! below are exactly what the proof needs. The shear before them does use
//! fused multiply-adds (one rounding instead of two, six instructions
//! fewer per test): a transformed vertex depends only on that vertex and
//! the ray, so every triangle sharing it still sees the same bits. Where
//! the CPU has no FMA, `wide` falls back to a multiply and a subtraction;
//! images are then still deterministic, but not bit-identical to an FMA
//! build's.
//!
//! On a long thin triangle (a sliver) seen near head-on the distance the
//! test weighs from its edge functions can be far off, though the inside
//! verdict stands; such hits take their distance from the triangle's
//! plane in f64 instead ([`confirm`]), outside the test itself.
//!
//! Triangles are stored as [`TriGroup`]s: the three vertices of [`TRI_WIDTH`]
//! triangles, one SIMD register per vertex coordinate, so a group test is a
//! straight run of vector arithmetic with no gathers.

use glam::Vec3;

use crate::lanes::{Vec3x8, per_axis};
use crate::scene::Triangles;

use super::{Lanes, TRI_WIDTH, TriLanes, WIDTH};
use crate::ray::NO_HIT;

/// [`TRI_WIDTH`] triangles, structure of arrays: the real ones in lanes
/// `0..len()`, then padding lanes with NaN vertices (every comparison
/// fails, so they never hit) and id [`PADDING`]. 320 bytes, aligned so
/// that a group is exactly five cache lines (at 32-byte alignment an
/// allocation could start mid-line, and then every group straddled six).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct TriGroup {
    /// `v[vertex][axis]`, one lane per triangle.
    pub v: [[TriLanes; 3]; 3],
    /// Global primitive id per lane, with [`SLIVER`] set on slivers: read
    /// through [`id`](Self::id) and [`slivers`](Self::slivers).
    ids: [u32; TRI_WIDTH],
}

/// The bit of [`TriGroup`]'s ids that marks a sliver: a triangle whose
/// longest edge squared exceeds [`SLIVER_ASPECT`] times twice its area.
/// Only on slivers can the watertight test's distance be far off when the
/// triangle is seen near head-on, which [`confirm`] repairs. (Primitive
/// ids stay below it: 2³⁰ triangles would take hundreds of GiB.)
const SLIVER: u32 = 1 << 30;

/// The id of a padding lane: the top bit set ([`TriGroup::len`]), the
/// [`SLIVER`] bit clear.
const PADDING: u32 = NO_HIT & !SLIVER;

/// See [`SLIVER`]: 1 for an equilateral triangle, 2 for half a square,
/// 4.25 for half of a 4 × 1 rectangle. Shadow rays leaving a fan of
/// slivers (the test in `tests/bvh_props.rs`, 20,000 rays per width)
/// first met the fan through the test's own distances at about 80 (3
/// rays; at 33, none; at 333, 236): 16 leaves a factor of five. The
/// CS184 scenes hold none (CBbunny, cow, beetle) to a few (maxplanck:
/// 10 of 50,801) to many (building: 3,422 of 39,506).
const SLIVER_ASPECT: f64 = 16.0;

impl TriGroup {
    /// Packs triangles `prims` (at most [`TRI_WIDTH`]) of `tris`.
    pub fn new(prims: &[u32], tris: &Triangles) -> TriGroup {
        debug_assert!(prims.len() <= TRI_WIDTH);
        let mut v = [[[f32::NAN; TRI_WIDTH]; 3]; 3];
        let mut ids = [PADDING; TRI_WIDTH];
        for (lane, &prim) in prims.iter().enumerate() {
            assert!(prim < SLIVER, "primitive id {prim} is too large");
            let corners = tris.vertices(prim as usize);
            for (k, p) in corners.iter().enumerate() {
                v[k][0][lane] = p.x;
                v[k][1][lane] = p.y;
                v[k][2][lane] = p.z;
            }
            ids[lane] = prim | if is_sliver(corners) { SLIVER } else { 0 };
        }
        TriGroup {
            v: v.map(|vertex| vertex.map(TriLanes::from)),
            ids,
        }
    }

    /// The primitive id of `lane`, a real (non-padding) lane.
    #[inline(always)]
    pub fn id(&self, lane: usize) -> u32 {
        self.ids[lane % TRI_WIDTH] & !SLIVER
    }

    /// The primitive ids of the real lanes.
    #[cfg(test)]
    pub fn prims(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.len() as usize).map(|lane| self.id(lane))
    }

    /// The lanes holding slivers.
    #[inline(always)]
    pub fn slivers(&self) -> u32 {
        const { assert!(SLIVER == 1 << 30) };
        (wide::u32x8::from(self.ids) << 1u32).to_bitmask()
    }

    /// Number of real (non-padding) triangles, without a branch (groups
    /// full and partial alternate along a ray's path): padding ids
    /// ([`PADDING`]) are the only ids with the top bit set (a scene has
    /// far fewer than 2³¹ primitives), so the lanes' sign mask counts
    /// them.
    #[inline]
    pub fn len(&self) -> u32 {
        const { assert!(TRI_WIDTH == 8 && PADDING >= 1 << 31 && PADDING & SLIVER == 0) };
        let padding = wide::u32x8::from(self.ids).to_bitmask();
        TRI_WIDTH as u32 - padding.count_ones()
    }
}

/// Whether the triangle with `corners` is a sliver ([`SLIVER`]), in f64.
/// A degenerate triangle (zero area) counts as one.
fn is_sliver(corners: [Vec3; 3]) -> bool {
    let [a, b, c] = corners.map(|p| p.as_dvec3());
    let longest = [b - a, c - b, a - c]
        .map(|e| e.length_squared())
        .into_iter()
        .fold(0.0, f64::max);
    let limit = SLIVER_ASPECT * (b - a).cross(c - a).length();
    longest > limit || limit.is_nan()
}

/// Per-ray constants of the watertight test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayTri {
    /// Axis along which the direction is largest (`kz`) and the other two,
    /// ordered so the transformed triangle keeps its winding.
    pub k: [usize; 3],
    /// Shear `(dx/dz, dy/dz)` and scale `1/dz` in the permuted frame.
    pub s: [f32; 3],
    /// Origin in the permuted frame.
    pub o: [f32; 3],
}

impl RayTri {
    /// Precomputes the shear for direction `d` (non-zero) from origin `o`:
    /// [`RayTriLanes`] run in one lane.
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> RayTri {
        let d8 = d.to_array().map(Lanes::splat);
        RayTriLanes::new(d8, d8.map(|d| Lanes::ONE / d)).ray(0, o)
    }
}

/// The direction-only part of [`RayTri`] for eight rays, computed with
/// vector instructions once per batch slot (the batch cull has the
/// reciprocal directions already): which axis is major, whether the other
/// two swap, and the shear.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RayTriLanes {
    /// Lanes whose major axis is x, and (of the others) y.
    major_x: u32,
    major_y: u32,
    /// Lanes whose direction is negative along the major axis: kx and ky
    /// swap, so the transformed triangle keeps its winding.
    flip: u32,
    /// `dx/dz`, `dy/dz`, `1/dz` in the permuted frame, per lane.
    shear: [[f32; WIDTH]; 3],
}

impl RayTriLanes {
    /// Setup for directions `d` with reciprocals `inv` (= 1 / `d`).
    #[inline(always)]
    pub fn new(d: [Lanes; 3], inv: [Lanes; 3]) -> RayTriLanes {
        let a = d.map(Lanes::abs);
        let major_x = a[0].simd_ge(a[1]) & a[0].simd_ge(a[2]);
        let major_y = !major_x & a[1].simd_ge(a[2]);
        // The component along axis kz, kx or ky of each lane, where
        // (kx, ky) = (1, 2), (2, 0), (0, 1) for kz = 0, 1, 2.
        let pick = |x: Lanes, y: Lanes, z: Lanes| major_x.select(x, major_y.select(y, z));
        let dz = pick(d[0], d[1], d[2]);
        let inv_dz = pick(inv[0], inv[1], inv[2]);
        let (d1, d2) = (pick(d[1], d[2], d[0]), pick(d[2], d[0], d[1]));
        let flip = dz.simd_lt(Lanes::ZERO);
        let (dx, dy) = (flip.select(d2, d1), flip.select(d1, d2));
        // One division (the cull's): the shear need not be the correctly
        // rounded d/dz, only the same for every triangle the ray is tested
        // against.
        RayTriLanes {
            major_x: major_x.to_bitmask(),
            major_y: major_y.to_bitmask(),
            flip: flip.to_bitmask(),
            shear: [dx * inv_dz, dy * inv_dz, inv_dz].map(Lanes::to_array),
        }
    }

    /// The permutation `[kx, ky, kz]` of the ray in `lane`.
    #[inline(always)]
    fn k(&self, lane: usize) -> [usize; 3] {
        let bit = |mask: u32| (mask >> lane) & 1 != 0;
        let kz = if bit(self.major_x) {
            0
        } else if bit(self.major_y) {
            1
        } else {
            2
        };
        // Arrays, not `Vec3` indexing (a match per component).
        let (mut kx, mut ky) = [(1, 2), (2, 0), (0, 1)][kz];
        if bit(self.flip) {
            std::mem::swap(&mut kx, &mut ky);
        }
        [kx, ky, kz]
    }

    /// The full setup of the ray in `lane`, whose origin is `o`.
    #[inline(always)]
    pub fn ray(&self, lane: usize, o: Vec3) -> RayTri {
        let k = self.k(lane);
        let o = o.to_array();
        let lane = lane % WIDTH;
        RayTri {
            k,
            s: std::array::from_fn(|j| self.shear[j][lane]),
            o: per_axis(|i| o[k[i]]),
        }
    }

    /// The setup of the rays in `active` (origins `o`, per axis) as one
    /// packet, if they share their permutation: the same major axis and
    /// the same sign along it, as coherent rays mostly do.
    #[inline(always)]
    pub fn packet(&self, active: u32, o: &[Lanes; 3]) -> Option<RayTriPacket> {
        debug_assert!(active != 0, "a packet has at least one ray");
        let uniform = |mask: u32| mask & active == 0 || mask & active == active;
        if !(uniform(self.major_x) && uniform(self.major_y) && uniform(self.flip)) {
            return None;
        }
        let k = self.k(active.trailing_zeros() as usize);
        Some(RayTriPacket {
            k,
            s: self.shear.map(TriLanes::from),
            o: per_axis(|i| o[k[i]]),
        })
    }
}

/// The triangle-test setup of a packet's rays: lane-wise when they share
/// one permutation (coherent rays), else one [`RayTri`] per lane.
#[derive(Clone, Copy, Debug)]
pub(crate) enum PacketTri {
    Shared(RayTriPacket),
    PerRay([RayTri; WIDTH]),
}

impl Default for PacketTri {
    /// A placeholder for the unused slots of a packet narrower than the
    /// widest (cheap to make, never read).
    fn default() -> PacketTri {
        PacketTri::Shared(RayTriPacket {
            k: [0, 1, 2],
            s: [TriLanes::ZERO; 3],
            o: [TriLanes::ZERO; 3],
        })
    }
}

impl PacketTri {
    /// The setup of the rays in `active` of a batch slot whose
    /// direction-only setup is `lanes` and origins are `o` (per axis).
    #[inline(always)]
    pub fn new(lanes: &RayTriLanes, active: u32, o: &[Lanes; 3]) -> PacketTri {
        match lanes.packet(active, o) {
            Some(shared) => PacketTri::Shared(shared),
            None => {
                let o = Vec3x8::new(o[0], o[1], o[2]);
                // A plain loop: `array::from_fn` here was left as a call.
                let mut tri = [lanes.ray(0, o.lane(0)); WIDTH];
                for (lane, t) in tri.iter_mut().enumerate().skip(1) {
                    *t = lanes.ray(lane, o.lane(lane));
                }
                PacketTri::PerRay(tri)
            }
        }
    }

    /// The setup of the ray in `lane` alone.
    #[inline(always)]
    pub fn ray(&self, lane: usize) -> RayTri {
        match self {
            // By reference: `p.s.map(..)` would copy each register to
            // the stack to read one lane of it.
            PacketTri::Shared(p) => RayTri {
                k: p.k,
                s: std::array::from_fn(|j| p.s[j].as_array()[lane % WIDTH]),
                o: std::array::from_fn(|j| p.o[j].as_array()[lane % WIDTH]),
            },
            PacketTri::PerRay(tri) => tri[lane % WIDTH],
        }
    }
}

/// [`RayTri`] for the rays of a packet that share one permutation, lane
/// by lane, so that one triangle can be tested against all of them at
/// once ([`intersect_rays`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayTriPacket {
    /// The shared permutation `[kx, ky, kz]`.
    pub k: [usize; 3],
    /// Shear and scale per lane, as in [`RayTri::s`].
    pub s: [TriLanes; 3],
    /// Origin per lane in the permuted frame.
    pub o: [TriLanes; 3],
}

/// Result of a group test: which lanes hit within `[0, t_far]`, and their
/// `t` and barycentric numerators/denominator.
pub(crate) struct GroupHit {
    pub mask: u32,
    pub t: TriLanes,
    pub v: TriLanes,
    pub w: TriLanes,
    pub det: TriLanes,
}

/// Tests the ray against all triangles of `g`. A lane hits if the ray
/// crosses its triangle at `t` in `[0, t_far]`.
#[inline(always)]
pub(crate) fn intersect_group(g: &TriGroup, r: &RayTri, t_far: f32) -> GroupHit {
    test_pairs(
        |vertex, axis| g.v[vertex][r.k[axis]],
        r.o.map(TriLanes::splat),
        r.s.map(TriLanes::splat),
        TriLanes::splat(t_far),
    )
}

/// Tests triangle `lane` of `g` against the rays of a packet that share
/// one permutation `k`: ray `i` (lane `i`) crosses it at `t` in
/// `[0, t_far[i]]`. Each lane computes exactly what [`intersect_group`]
/// computes for that ray and triangle.
#[inline(always)]
pub(crate) fn intersect_rays(
    g: &TriGroup,
    lane: usize,
    rays: &RayTriPacket,
    t_far: Lanes,
) -> GroupHit {
    test_pairs(
        |vertex, axis| TriLanes::splat(g.v[vertex][rays.k[axis]].as_array()[lane]),
        rays.o,
        rays.s,
        t_far,
    )
}

/// The watertight test on [`TRI_WIDTH`] (ray, triangle) pairs, one per
/// lane: `p(vertex, axis)` gives each lane's triangle vertex along its
/// ray's permuted axis (0, 1, 2 = kx, ky, kz), `o` and `s` the ray's
/// permuted origin and shear (see [`RayTri`]), `t_far` the end of the ray.
#[inline(always)]
fn test_pairs(
    p: impl Fn(usize, usize) -> TriLanes,
    [ox, oy, oz]: [TriLanes; 3],
    [sx, sy, sz]: [TriLanes; 3],
    t_far: TriLanes,
) -> GroupHit {
    // Vertices relative to the origin, then sheared so the ray is +z.
    let az = p(0, 2) - oz;
    let bz = p(1, 2) - oz;
    let cz = p(2, 2) - oz;
    // Fused: safe for watertightness here, not below (module docs).
    let ax = sx.mul_neg_add(az, p(0, 0) - ox);
    let ay = sy.mul_neg_add(az, p(0, 1) - oy);
    let bx = sx.mul_neg_add(bz, p(1, 0) - ox);
    let by = sy.mul_neg_add(bz, p(1, 1) - oy);
    let cx = sx.mul_neg_add(cz, p(2, 0) - ox);
    let cy = sy.mul_neg_add(cz, p(2, 1) - oy);

    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;

    // Exact zeros: the ray passes (numerically) through an edge or vertex.
    // Redo those lanes in double precision, where the products are exact.
    let zero = TriLanes::ZERO;
    let any_zero = (u.simd_eq(zero) | v.simd_eq(zero) | w.simd_eq(zero)).to_bitmask();
    if any_zero != 0 {
        refine_edges_f64(any_zero, [ax, ay, bx, by, cx, cy], &mut u, &mut v, &mut w);
    }

    // Inside iff the three edge functions do not disagree in sign
    // (both orientations accepted: no back-face culling).
    let neg = u.simd_lt(zero) | v.simd_lt(zero) | w.simd_lt(zero);
    let pos = u.simd_gt(zero) | v.simd_gt(zero) | w.simd_gt(zero);
    let det = u + v + w;
    // Ordered comparisons: a NaN det (padding lanes, degenerate triangles)
    // is not inside, so groups with padding can take the early exit too.
    let inside = !(neg & pos) & (det.simd_lt(zero) | det.simd_gt(zero));
    // Most groups a ray reaches have no triangle it passes through: skip
    // the distance (and its division) for those.
    if inside.to_bitmask() == 0 {
        return GroupHit {
            mask: 0,
            t: zero,
            v,
            w,
            det,
        };
    }
    let t_num = u * (sz * az) + v * (sz * bz) + w * (sz * cz);
    let t = t_num / det;
    let ok = inside & t.simd_ge(zero) & t.simd_le(t_far);
    GroupHit {
        mask: ok.to_bitmask(),
        t,
        v,
        w,
        det,
    }
}

/// Confirms the hits `h.mask` of [`intersect_group`] for the ray `r`, run
/// with its range open to +∞ when the group holds slivers
/// (`traverse::sliver_range`), and returns the lanes left: those whose
/// distance lies in `[0, t_far]`, measured again from the triangle's
/// plane in f64 for slivers where the test's own is ill-conditioned
/// ([`confirm_slivers`]). `ANY_HIT` queries need only the verdict; a
/// closest-hit query may get back other lanes beyond `t_far`, which its
/// nearest-so-far test drops anyway.
#[inline(always)]
pub(crate) fn confirm<const ANY_HIT: bool>(
    g: &TriGroup,
    r: &RayTri,
    h: &mut GroupHit,
    t_far: f32,
) -> u32 {
    let slivers = g.slivers() & h.mask;
    // A closest-hit query's caller drops hits beyond its nearest so far
    // itself.
    if ANY_HIT {
        h.mask &= h.t.simd_le(TriLanes::splat(t_far)).to_bitmask() | slivers;
    }
    if slivers != 0 {
        group_slivers(g, r, slivers, t_far, h);
    }
    h.mask
}

/// [`confirm`] for the closest hits of [`intersect_rays`] (lanes = rays,
/// the triangle in `lane` of `g`).
#[inline(always)]
pub(crate) fn confirm_rays(
    g: &TriGroup,
    lane: usize,
    rays: &RayTriPacket,
    h: &mut GroupHit,
    t_far: Lanes,
) -> u32 {
    let slivers = if g.slivers() & (1 << lane) != 0 {
        h.mask
    } else {
        0
    };
    if slivers != 0 {
        ray_slivers(g, lane, rays, slivers, t_far, h);
    }
    h.mask
}

/// [`confirm_slivers`] for [`confirm`]. Out of line, and taking the ray
/// setup by reference: broadcasts built for the call were otherwise
/// hoisted into every ray's setup (+65 instructions per diffuse ray on
/// CBbunny; passing the setup by value, or as scalars, measured 10 to 60
/// more per ray than this).
#[cold]
#[inline(never)]
fn group_slivers(g: &TriGroup, r: &RayTri, lanes: u32, t_far: f32, h: &mut GroupHit) {
    confirm_slivers(
        |vertex, axis| g.v[vertex][r.k[axis]],
        (r.o.map(TriLanes::splat), r.s.map(TriLanes::splat)),
        lanes,
        TriLanes::splat(t_far),
        h,
    );
}

/// [`confirm_slivers`] for [`confirm_rays`], as [`group_slivers`].
#[cold]
#[inline(never)]
fn ray_slivers(
    g: &TriGroup,
    lane: usize,
    rays: &RayTriPacket,
    lanes: u32,
    t_far: Lanes,
    h: &mut GroupHit,
) {
    confirm_slivers(
        |vertex, axis| TriLanes::splat(g.v[vertex][rays.k[axis]].as_array()[lane]),
        (rays.o, rays.s),
        lanes,
        t_far,
        h,
    );
}

/// Confirms the sliver lanes `lanes` of a [`test_pairs`] hit `h` (same
/// arguments): `h.mask` keeps those whose distance lies in `[0, t_far]`.
///
/// The test's distance `t = sz·(u·az + v·bz + w·cz) / det` weighs the
/// vertices' depths by the edge functions. Each edge function is a
/// difference of two products and carries an error up to ε times their
/// magnitudes; with `Σ` the sum of all six products' magnitudes, `t` is
/// accurate to a few ε when `Σ` is close to `|det|`, as for a well-shaped
/// triangle seen head-on. For a long thin sliver `Σ` can exceed `|det|` a
/// millionfold and `t` be off by half, outside the triangle's own box:
/// the hierarchy (which culls by boxes) disagreed with brute force, and
/// shadow rays met the sliver they left. A pair is ill-conditioned when
/// `Σ > 4·|det|`, a property of the pair alone, so that its distance is
/// the same number in every query and structure; those lanes take the
/// distance from the plane in f64 ([`plane_distances_f64`]).
///
/// (Any-hit queries once kept an ill-conditioned lane without the f64
/// pass when `t` lay inside the range by more than an error bound on the
/// products' rounding; a review found rays at grazing incidence whose
/// error, from the rounding of the sheared vertices themselves, broke it
/// sevenfold, so any-hit queries now measure every such lane too.)
///
/// What this does not repair: a well-shaped triangle seen nearly edge-on
/// is ill-conditioned too, but is not checked (that would cost every hit
/// the work below, +18% instructions per diffuse ray on CBbunny); and an
/// ill-conditioned sliver whose f32 distance lies below 0 while its true
/// one does not is never offered here (the test drops it) and stays a
/// miss.
#[inline(always)]
fn confirm_slivers(
    p: impl Fn(usize, usize) -> TriLanes,
    ([ox, oy, oz], [sx, sy, sz]): ([TriLanes; 3], [TriLanes; 3]),
    lanes: u32,
    t_far: TriLanes,
    h: &mut GroupHit,
) {
    let az = p(0, 2) - oz;
    let bz = p(1, 2) - oz;
    let cz = p(2, 2) - oz;
    let ax = sx.mul_neg_add(az, p(0, 0) - ox);
    let ay = sy.mul_neg_add(az, p(0, 1) - oy);
    let bx = sx.mul_neg_add(bz, p(1, 0) - ox);
    let by = sy.mul_neg_add(bz, p(1, 1) - oy);
    let cx = sx.mul_neg_add(cz, p(2, 0) - ox);
    let cy = sy.mul_neg_add(cz, p(2, 1) - oy);
    let products = (cx * by).abs()
        + (cy * bx).abs()
        + (ax * cy).abs()
        + (ay * cx).abs()
        + (bx * ay).abs()
        + (by * ax).abs();
    let unsure = products
        .simd_gt(TriLanes::splat(4.0) * h.det.abs())
        .to_bitmask()
        & lanes;
    // Well-conditioned lanes keep the f32 verdict at the true end.
    h.mask = (h.mask & !lanes) | (lanes & !unsure & h.t.simd_le(t_far).to_bitmask());
    if unsure != 0 {
        plane_distances_f64(unsure, &p, [ox, oy, oz], [sx, sy, sz], t_far, h);
    }
}

/// The distances of the lanes in `lanes` from the triangle's plane, in
/// f64 in the ray's permuted frame, where the direction is
/// `(sx, sy, 1) / sz`: `t = sz·(n·a) / (n·(sx, sy, 1))` with `a` the first
/// vertex relative to the origin and `n = (b − a) × (c − a)`. The vertex
/// differences are exact in f64 and the products nearly so, whatever the
/// triangle's shape. Lanes whose distance leaves `[0, t_far]` (or is
/// undefined: the plane parallel to the ray) are left out of `h.mask`, the
/// others put in.
#[cold]
#[inline(never)]
fn plane_distances_f64(
    lanes: u32,
    p: &impl Fn(usize, usize) -> TriLanes,
    o: [TriLanes; 3],
    s: [TriLanes; 3],
    t_far: TriLanes,
    h: &mut GroupHit,
) {
    let mut t = h.t.to_array();
    let t_far = t_far.to_array();
    let (o, s) = (o.map(TriLanes::to_array), s.map(TriLanes::to_array));
    let vertex = |k: usize| [0, 1, 2].map(|axis| p(k, axis).to_array());
    let v = [vertex(0), vertex(1), vertex(2)];
    for i in crate::lanes::each(lanes) {
        let rel = |k: usize| -> [f64; 3] {
            std::array::from_fn(|axis| v[k][axis][i] as f64 - o[axis][i] as f64)
        };
        let (a, b, c) = (rel(0), rel(1), rel(2));
        let e1: [f64; 3] = std::array::from_fn(|j| b[j] - a[j]);
        let e2: [f64; 3] = std::array::from_fn(|j| c[j] - a[j]);
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let along = n[0] * s[0][i] as f64 + n[1] * s[1][i] as f64 + n[2];
        let dist = s[2][i] as f64 * (n[0] * a[0] + n[1] * a[1] + n[2] * a[2]) / along;
        // Compared once rounded, so that a query ending at this very
        // distance (as returned) still finds it; NaN fails both, and a
        // plane nearly parallel to the ray may put it at +∞, no hit.
        t[i] = dist as f32;
        if t[i] >= 0.0 && t[i] <= t_far[i] && t[i] < f32::INFINITY {
            h.mask |= 1 << i;
        }
    }
    h.t = TriLanes::from(t);
}

/// Recomputes the edge functions of the lanes in `lanes` in f64.
#[cold]
#[inline(never)]
fn refine_edges_f64(
    lanes: u32,
    p: [TriLanes; 6],
    u: &mut TriLanes,
    v: &mut TriLanes,
    w: &mut TriLanes,
) {
    let (mut uu, mut vv, mut ww) = (u.to_array(), v.to_array(), w.to_array());
    // The arrays are made here, in the cold path: as an argument, their
    // `map` was a call in every caller's hot loop.
    let [ax, ay, bx, by, cx, cy] = p.map(TriLanes::to_array);
    let mut bits = lanes;
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let (ax, ay, bx, by, cx, cy) = (
            ax[i] as f64,
            ay[i] as f64,
            bx[i] as f64,
            by[i] as f64,
            cx[i] as f64,
            cy[i] as f64,
        );
        uu[i] = (cx * by - cy * bx) as f32;
        vv[i] = (ax * cy - ay * cx) as f32;
        ww[i] = (bx * ay - by * ax) as f32;
    }
    *u = TriLanes::from(uu);
    *v = TriLanes::from(vv);
    *w = TriLanes::from(ww);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-ray setup the lane form replaced, kept as the reference.
    fn scalar_ray_tri(o: Vec3, d: Vec3) -> RayTri {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (d, o) = (d.to_array(), o.to_array());
        let (mut kx, mut ky) = [(1, 2), (2, 0), (0, 1)][kz];
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let inv_dz = 1.0 / d[kz];
        RayTri {
            k: [kx, ky, kz],
            s: [d[kx] * inv_dz, d[ky] * inv_dz, inv_dz],
            o: [o[kx], o[ky], o[kz]],
        }
    }

    /// Triangles are flagged as slivers by shape alone (longest edge
    /// squared against twice the area, [`SLIVER_ASPECT`]), whatever their
    /// size, position or orientation; the flag leaves ids and the
    /// padding count intact.
    #[test]
    fn slivers_are_flagged_by_shape() {
        // (corners in the plane, sliver?)
        let shapes: [([[f32; 2]; 3], bool); 7] = [
            ([[0.0, 0.0], [1.0, 0.0], [0.5, 0.866]], false), // equilateral: 1.15
            ([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], false),   // half a square: 2
            ([[0.0, 0.0], [4.0, 0.0], [4.0, 1.0]], false),   // 4 × 1: 4.25
            ([[0.0, 0.0], [15.0, 0.0], [15.0, 1.0]], false), // 15 × 1: 15.03
            ([[0.0, 0.0], [17.0, 0.0], [17.0, 1.0]], true),  // 17 × 1: 17.03
            ([[0.0, 0.0], [10.0, 0.0], [0.0, 0.03]], true),  // a fan's blade
            ([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], true),    // degenerate
        ];
        for (scale, offset) in [(1.0f32, 0.0f32), (1e-3, 10.0), (1e3, -5.0)] {
            // An orthonormal frame tilted out of every axis plane.
            let u = Vec3::new(1.0, 0.5, 0.2).normalize();
            let v = u.cross(Vec3::new(0.3, -1.0, 0.7)).normalize();
            let place = |[x, y]: [f32; 2]| (x * u + y * v) * scale + Vec3::splat(offset);
            let mut tris = Triangles::default();
            for (corners, _) in &shapes {
                let first = tris.positions.len() as u32;
                tris.positions.extend(corners.iter().map(|&c| place(c)));
                tris.indices.push([first, first + 1, first + 2]);
            }
            let prims: Vec<u32> = (0..shapes.len() as u32).rev().collect();
            let g = TriGroup::new(&prims, &tris);
            assert_eq!(g.len(), shapes.len() as u32);
            for (lane, &prim) in prims.iter().enumerate() {
                assert_eq!(g.id(lane), prim);
                let want = shapes[prim as usize].1;
                assert_eq!(
                    g.slivers() & (1 << lane) != 0,
                    want,
                    "shape {prim} at scale {scale}"
                );
            }
        }
    }

    /// Ties between axes, negative and −0 components, tiny magnitudes.
    const DIRECTIONS: [Vec3; 9] = [
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(-1.0, 1.0, 0.5),
        Vec3::new(0.5, -2.0, 2.0),
        Vec3::new(0.0, -0.0, -3.0),
        Vec3::new(-0.0, 0.7, -0.7),
        Vec3::new(3.0, -3.0, 0.1),
        Vec3::new(1e-30, -2e-30, 5e-31),
        Vec3::new(-0.3, -0.4, -0.5),
        Vec3::new(2.0, 0.0, -0.0),
    ];

    /// Eight of [`DIRECTIONS`] from `shift` on, and their lane setup.
    fn setup(shift: usize) -> ([Vec3; WIDTH], RayTriLanes) {
        let n = DIRECTIONS.len();
        let d: [Vec3; WIDTH] = std::array::from_fn(|l| DIRECTIONS[(l + shift) % n]);
        let axis = |k: usize| Lanes::from(d.map(|v| v[k]));
        let d8 = [axis(0), axis(1), axis(2)];
        (d, RayTriLanes::new(d8, d8.map(|x| Lanes::ONE / x)))
    }

    #[test]
    fn lane_setup_is_the_scalar_setup() {
        // Each direction in every lane position.
        for shift in 0..DIRECTIONS.len() {
            let (d, lanes) = setup(shift);
            let o: [Vec3; WIDTH] =
                std::array::from_fn(|l| Vec3::new(l as f32, -2.0 * l as f32, 0.5));
            for l in 0..WIDTH {
                let (got, want) = (lanes.ray(l, o[l]), scalar_ray_tri(o[l], d[l]));
                assert_eq!(got.k, want.k, "{:?}", d[l]);
                assert_eq!(
                    got.s.map(f32::to_bits),
                    want.s.map(f32::to_bits),
                    "{:?}",
                    d[l]
                );
                assert_eq!(
                    got.o.map(f32::to_bits),
                    want.o.map(f32::to_bits),
                    "{:?}",
                    d[l]
                );
            }
        }
    }

    /// Rays make one packet exactly when they share the permutation of
    /// the triangle test (major axis and its sign), and the packet has
    /// it: otherwise packets fall back to ray-by-ray tests, which give the
    /// same hits but forgo the speed they exist for.
    #[test]
    fn rays_make_a_packet_exactly_when_they_share_a_permutation() {
        let o = [Lanes::ZERO; 3];
        let mut packets = 0;
        for shift in 0..DIRECTIONS.len() {
            let (d, lanes) = setup(shift);
            for active in 1u32..1 << WIDTH {
                let ks: Vec<[usize; 3]> = crate::lanes::each(active)
                    .map(|l| scalar_ray_tri(Vec3::ZERO, d[l]).k)
                    .collect();
                let shared = ks.iter().all(|&k| k == ks[0]);
                let packet = lanes.packet(active, &o);
                assert_eq!(packet.is_some(), shared, "rays {active:08b}: {ks:?}");
                if let Some(p) = packet {
                    assert_eq!(p.k, ks[0], "rays {active:08b}");
                    packets += usize::from(ks.len() > 1);
                }
            }
        }
        assert!(packets > 0, "no packet of two or more rays was tested");
    }
}
