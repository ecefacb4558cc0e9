//! Single-ray traversal of the wide BVH, applied ray by ray over a batch,
//! and what every traversal shares: the batch cull, the slab test and the
//! leaf tests (including a packet's, one batch slot at a time).
//!
//! Each ray walks the tree with a small fixed-size stack that lives for the
//! whole batch (no allocation per ray). At every wide node all children's
//! boxes are tested at once with a slab test; the children that are hit are
//! visited nearest first, the rest pushed with their entry distance so that
//! a closest-hit query can drop them once a nearer hit is known.
//!
//! # Robust slab test
//!
//! For an axis with inverse direction `inv`, the ray is between the two
//! planes of a box for `t` between `(near − o)·inv` and `(far − o)·inv`,
//! where "near" is the min plane if `inv ≥ 0` and the max plane otherwise.
//! Choosing the planes by the sign of the direction, once per ray, instead
//! of sorting the two distances per box, also makes the inverted boxes of
//! empty slots (min = +∞, max = −∞) yield an empty interval.
//!
//! Rounding can make the computed exit distance slightly too small, so a
//! ray grazing a box could miss a triangle lying on its face. Following Ize,
//! "Robust BVH Ray Traversal" (JCGT 2013), the exit distance is multiplied
//! by `1 + 2γ₃` (γₙ = nε/(1−nε)), which bounds the error of the subtraction
//! and the multiplication.
//!
//! A zero direction component gives `inv = ±∞`: the slab distances are ±∞
//! (the ray never crosses that plane) unless the origin lies exactly on the
//! plane, where `0·∞ = NaN`. Such a ray runs inside the box's face, and the
//! face counts as part of the box (brute force would report a hit on a
//! triangle edge lying there), so NaN must mean "no constraint". The
//! running `max`/`min` are written as `candidate.fast_max(running)`, which maps
//! to `maxps`: when either operand is NaN it returns the second, so a NaN
//! candidate is simply ignored.

use glam::Vec3;
use wide::i32x8;

use super::flatten::{ChildRef, WideNode};
use super::packet::{MAX_RAYS, RayLanes};
use super::sphere::{PackedSphere, intersect_sphere};
use super::triangle::{
    GroupHit, PacketTri, RayTri, RayTriLanes, TriGroup, confirm, confirm_rays, intersect_group,
    intersect_rays,
};
use super::{Lanes, WIDTH};
use crate::lanes::{from_bits, per_axis, to_bits};
use crate::prefetch::prefetch_all;
use crate::ray::NO_HIT;

/// γ₃ = 3ε / (1 − 3ε) for f32 (ε = 2⁻²⁴, half an ULP of 1).
pub(crate) const GAMMA3: f32 = 3.0 * (f32::EPSILON * 0.5) / (1.0 - 3.0 * (f32::EPSILON * 0.5));

/// Slack on the ray's `t_far` (the end of the ray, or the nearest hit so
/// far) when culling boxes.
///
/// A triangle's `t` comes from different arithmetic than the slab
/// distances of its box, so a ray that ends exactly on a triangle (or ties
/// with the nearest hit) can see the box's entry slightly beyond the
/// triangle's `t`. The rounding errors of both are a few ULPs of the
/// *coordinates* involved, which, divided by the ray's speed along its
/// major axis, can be far more than a few ULPs of a small `t`. So the cull
/// distance is `t_far·(1 + 32ε) + 32ε·M/|d|∞` with `M` bounding the
/// magnitude of every coordinate (scene bounds and origin). This is a
/// generous bound, not a proof; the property tests end rays exactly at
/// their brute-force hits to check it. The cost is a few extra box visits
/// within ~1e-6 of the scene size from the end of a ray.
pub(crate) const SLACK_ULPS: f32 = 32.0 * f32::EPSILON;
pub(crate) const T_FAR_MARGIN: f32 = 1.0 + SLACK_ULPS;

/// Stack capacity: the builder bounds the binary depth to well under 96,
/// a wide level pushes at most `WIDTH − 1` entries, and every push writes
/// `WIDTH` (see [`push_children`]).
pub(crate) const STACK_SIZE: usize = 96 * (WIDTH - 1) + WIDTH + 1;

/// What traversal reads: the flattened tree and its leaf arrays.
pub(crate) struct Scene<'a> {
    pub nodes: &'a [WideNode],
    pub tri_groups: &'a [TriGroup],
    pub spheres: &'a [PackedSphere],
    pub root: ChildRef,
    /// Largest coordinate magnitude in the scene bounds.
    pub extent: f32,
}

/// Per-ray constants of the slab test.
pub(crate) struct RayBox {
    o: [Lanes; 3],
    inv: [Lanes; 3],
    /// 0 if the direction along the axis is positive (enter at min), else 1.
    near: [usize; 3],
    /// Absolute slack added to `t_far` when culling (see [`SLACK_ULPS`]).
    slack: f32,
}

impl RayBox {
    /// Boxes entered beyond this are culled (see [`SLACK_ULPS`]).
    #[inline(always)]
    fn cull(&self, t_far: f32) -> f32 {
        t_far * T_FAR_MARGIN + self.slack
    }

    /// Returns the mask of children hit within `[0, t_far]` and their entry distances.
    #[inline(always)]
    fn test(&self, node: &WideNode, t_far: f32) -> (u32, Lanes) {
        let (hit, t_enter) = self.test_lanes(node, t_far);
        (hit.to_bitmask(), t_enter)
    }

    /// [`test`](Self::test) with the mask as all-ones lanes.
    #[inline(always)]
    pub fn test_lanes(&self, node: &WideNode, t_far: f32) -> (Lanes, Lanes) {
        let b = &node.bounds;
        // `& 1`: the plane indices are 0 or 1, which lets the compiler drop
        // six bounds checks per node.
        let n = per_axis(|a| self.near[a] & 1);
        let f = per_axis(|a| (self.near[a] ^ 1) & 1);
        slab_test(
            [b[0][n[0]], b[1][n[1]], b[2][n[2]]],
            [b[0][f[0]], b[1][f[1]], b[2][f[2]]],
            &self.o,
            &self.inv,
            Lanes::splat(self.cull(t_far)),
        )
    }
}

/// The slab test behind every box query — one ray against a node's
/// children, a packet's rays against one child, a batch's rays against the
/// scene box — so all of them make the same decision for the same ray and
/// box: entry and exit distances from the `near` and `far` planes of each
/// axis, the exit widened by 1 + 2γ₃ (Ize) and capped at `cull`. Returns
/// the lanes entered within `[0, cull]` (all ones) and their entry distances.
#[inline(always)]
pub(crate) fn slab_test<L: RayLanes>(
    near: [L; 3],
    far: [L; 3],
    o: &[L; 3],
    inv: &[L; 3],
    cull: L,
) -> (L, L) {
    let mut t_enter = L::splat(0.0);
    let mut t_exit = L::splat(f32::INFINITY);
    for axis in 0..3 {
        let t0 = (near[axis] - o[axis]) * inv[axis];
        let t1 = (far[axis] - o[axis]) * inv[axis];
        // Candidate first: a NaN candidate (origin on the plane, zero
        // direction) leaves the running bound unchanged.
        t_enter = t0.fast_max(t_enter);
        t_exit = t1.fast_min(t_exit);
    }
    let t_exit = (t_exit * L::splat(1.0 + 2.0 * GAMMA3)).fast_min(cull);
    (t_enter.le(t_exit), t_enter)
}

/// What the batch cull ([`may_hit`]) found for (up to) [`WIDTH`] rays,
/// kept so that each ray's own setup need not redo it.
pub(crate) struct Cull {
    /// The rays that may hit the box.
    pub mask: u32,
    /// Reciprocal directions, per axis and lane.
    inv: [[f32; WIDTH]; 3],
    /// Absolute cull slack per lane (see [`SLACK_ULPS`]).
    slack: [f32; WIDTH],
    /// Lanes whose direction is negative (1/d < 0, including −0), per axis.
    negative: [u32; 3],
    /// The triangle test's per-ray setup (a placeholder when `mask` is 0:
    /// no ray of the slot is traced).
    tri: RayTriLanes,
}

impl Cull {
    /// Reciprocal directions of the eight lanes, per axis.
    #[inline(always)]
    pub fn inv(&self) -> [Lanes; 3] {
        self.inv.map(Lanes::from)
    }

    /// Lanes whose direction along `axis` is negative (1/d < 0,
    /// including −0), as bits.
    #[inline(always)]
    pub fn negative(&self, axis: usize) -> u32 {
        self.negative[axis]
    }

    /// Absolute cull slack of the eight lanes.
    #[inline(always)]
    pub fn slack(&self) -> Lanes {
        Lanes::from(self.slack)
    }

    /// Slab-test constants of the ray in `lane`, whose origin is `o`: the
    /// values the cull computed, so box decisions agree exactly.
    #[inline(always)]
    pub fn ray_box(&self, lane: usize, o: Vec3) -> RayBox {
        RayBox {
            o: [Lanes::splat(o.x), Lanes::splat(o.y), Lanes::splat(o.z)],
            inv: per_axis(|axis| Lanes::splat(self.inv[axis][lane])),
            near: per_axis(|axis| ((self.negative[axis] >> lane) & 1) as usize),
            slack: self.slack[lane],
        }
    }

    /// Triangle-test setup of the ray in `lane`, whose origin is `o`.
    #[inline(always)]
    pub fn ray_tri(&self, lane: usize, o: Vec3) -> RayTri {
        self.tri.ray(lane, o)
    }

    /// Triangle-test setup of the rays in `active` as a packet; their
    /// origins are `o` per axis.
    #[inline(always)]
    pub fn packet_tri(&self, active: u32, o: &[Lanes; 3]) -> PacketTri {
        PacketTri::new(&self.tri, active, o)
    }
}

/// Which of the (up to) [`WIDTH`] rays `start..` of `rays` may hit the box
/// `bounds` (min, max corner) within `[0, t_max]`, as a bit mask. Rays
/// that cannot hit anything at all ([`never_hits`]) are never in it, so
/// the traversals need not check them again.
///
/// This is the slab test of [`RayBox::test`] run across rays instead of
/// across boxes, straight from the structure-of-arrays batch: a cheap
/// filter that lets rays missing the whole scene (often most camera rays)
/// skip the per-ray setup. It uses the same arithmetic as the per-ray test
/// on a box that contains all children of the root, so it never rejects a
/// ray the traversal would accept (IEEE operations are monotone).
#[inline(always)]
pub(crate) fn may_hit(bounds: &[[f32; 3]; 2], extent: f32, rays: &Ray8Src, start: usize) -> Cull {
    let end = (start + WIDTH).min(rays.t_max.len());
    let (o, dir) = rays.lanes(start);
    let t_max = crate::lanes::load(rays.t_max, start);
    // `never_hits`, lane by lane: a finite value is below ∞ in magnitude
    // (NaN compares false), a usable direction has a component of normal
    // magnitude, and an interval is empty if t_max is NaN or negative.
    let finite = |v: Lanes| v.abs().simd_lt(Lanes::splat(f32::INFINITY));
    let normal = |v: Lanes| v.abs().simd_ge(Lanes::splat(f32::MIN_POSITIVE));
    let valid = finite(o[0])
        & finite(o[1])
        & finite(o[2])
        & finite(dir[0])
        & finite(dir[1])
        & finite(dir[2])
        & (normal(dir[0]) | normal(dir[1]) | normal(dir[2]))
        & t_max.simd_ge(Lanes::ZERO);
    let inv = dir.map(|d| Lanes::ONE / d);
    let min_inv = inv
        .iter()
        .fold(Lanes::splat(f32::INFINITY), |m, i| i.abs().fast_min(m));
    // Near plane per lane by the sign of the direction, exactly as the
    // per-ray test picks it (sorting the two distances would mishandle the
    // NaN of a ray lying in a face plane).
    let positive = inv.map(|i| i.simd_ge(Lanes::ZERO));
    let (lo, hi) = (bounds[0].map(Lanes::splat), bounds[1].map(Lanes::splat));
    let near = per_axis(|a| positive[a].select(lo[a], hi[a]));
    let far = per_axis(|a| positive[a].select(hi[a], lo[a]));
    // Cull slack (see `SLACK_ULPS`): 32ε·(extent + |o|∞)/|d|∞, with 1/|d|∞
    // taken as the smallest |1/dᵢ| (the same value, as division is
    // correctly rounded and monotone).
    let max_abs_o = o[0].abs().fast_max(o[1].abs()).fast_max(o[2].abs());
    let slack = Lanes::splat(SLACK_ULPS) * (Lanes::splat(extent) + max_abs_o) * min_inv;
    let t_cull = t_max * Lanes::splat(T_FAR_MARGIN) + slack;
    let (hit, _) = slab_test(near, far, &o, &inv, t_cull);
    let mask = hit.to_bitmask() & valid.to_bitmask() & ((1u32 << (end - start)) - 1);
    Cull {
        mask,
        inv: inv.map(Lanes::to_array),
        slack: slack.to_array(),
        // ±0 gives ±∞, whose sign still picks the right near plane.
        negative: positive.map(|p| !p.to_bitmask() & 0xff),
        // No ray of the slot will test a triangle if none passed.
        tri: if mask != 0 {
            RayTriLanes::new(dir, inv)
        } else {
            RayTriLanes::default()
        },
    }
}

/// The component arrays of a ray batch, as [`may_hit`] reads them.
pub(crate) struct Ray8Src<'a> {
    pub org: [&'a [f32]; 3],
    pub dir: [&'a [f32]; 3],
    pub t_max: &'a [f32],
}

impl Ray8Src<'_> {
    /// Origins and directions of rays `start..start + WIDTH`, per axis
    /// (zeros past the batch's end; directions through [`flush_subnormal`]).
    #[inline(always)]
    pub fn lanes(&self, start: usize) -> ([Lanes; 3], [Lanes; 3]) {
        let end = (start + WIDTH).min(self.t_max.len());
        let load = |v: &[f32]| crate::lanes::load(&v[..end], start);
        let (o, d) = (self.org, self.dir);
        let flush = |d: Lanes| {
            d.abs()
                .simd_lt(Lanes::splat(f32::MIN_POSITIVE))
                .select(d * Lanes::ZERO, d)
        };
        (
            [load(o[0]), load(o[1]), load(o[2])],
            [flush(load(d[0])), flush(load(d[1])), flush(load(d[2]))],
        )
    }
}

/// A direction with its subnormal components made zeros (of the same
/// sign), as every query reads directions. Below ~2.9e-39 their
/// reciprocals overflow, so the box test took the ray for parallel to that
/// axis while the triangle test, from the direction itself, did not, and a
/// ray crossing a box face within ~1e-38 of a plane missed a hit that
/// brute force found; the whole subnormal range is flushed, the rule the
/// API documents. (For a direction with a normal component of ordinary
/// size this moves the ray by nothing f32 coordinates can show; a
/// direction wholly near the subnormal range may turn.)
#[inline(always)]
pub(crate) fn flush_subnormal(d: Vec3) -> Vec3 {
    Vec3::select(d.abs().cmplt(Vec3::splat(f32::MIN_POSITIVE)), d * 0.0, d)
}

/// Rays that cannot hit anything: a direction that is zero or subnormal
/// in every component (1/d overflows, and the triangle test's shear with
/// it) or not finite, a non-finite origin, or an empty (negative or NaN)
/// interval.
#[inline(always)]
pub(crate) fn never_hits(o: Vec3, d: Vec3, t_max: f32) -> bool {
    d.abs().max_element() < f32::MIN_POSITIVE
        || !d.is_finite()
        || !o.is_finite()
        || t_max.is_nan()
        || t_max < 0.0
}

/// Closest hit of one ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Closest {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

impl Closest {
    /// Takes the hit in `lane` of `h` (at `t`, on primitive `id`) if it is
    /// nearer. Exact ties go to the lower id, so the result does not depend
    /// on the order the tree is walked in (single ray or packet) nor on
    /// which lane of which test found the hit.
    #[inline(always)]
    fn offer(&mut self, t: f32, id: u32, h: &GroupHit, lane: usize) {
        if t < self.t || (t == self.t && id < self.prim) {
            let det = h.det.to_array()[lane];
            *self = Closest {
                t,
                prim: id,
                u: h.v.to_array()[lane] / det,
                v: h.w.to_array()[lane] / det,
            };
        }
    }

    /// No hit yet on a ray that ends at `t_max`.
    pub fn none(t_max: f32) -> Closest {
        Closest {
            t: t_max,
            prim: NO_HIT,
            u: 0.0,
            v: 0.0,
        }
    }
}

/// The closest hits so far of a packet's rays, structure of arrays: the
/// packet's far ends load as one register, and the results store as a few
/// vectors.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct ClosestLanes {
    pub t: [f32; MAX_RAYS],
    pub prim: [u32; MAX_RAYS],
    pub u: [f32; MAX_RAYS],
    pub v: [f32; MAX_RAYS],
}

impl ClosestLanes {
    /// No hit yet on rays that end at `t_max` (lanes past its end: at 0).
    #[inline(always)]
    pub fn none(t_max: &[f32]) -> ClosestLanes {
        let mut t = [0.0; MAX_RAYS];
        t[..t_max.len()].copy_from_slice(t_max);
        ClosestLanes {
            t,
            prim: [NO_HIT; MAX_RAYS],
            u: [0.0; MAX_RAYS],
            v: [0.0; MAX_RAYS],
        }
    }

    /// The nearest hits so far of the rays of batch slot `slot`.
    #[inline(always)]
    pub fn t_slot(&self, slot: usize) -> Lanes {
        let first = WIDTH * slot;
        Lanes::from(<[f32; WIDTH]>::try_from(&self.t[first..first + WIDTH]).unwrap())
    }

    /// Runs `narrow` on the closest hit of ray `i` so far, as a
    /// [`Closest`], and keeps what it leaves.
    #[inline(always)]
    pub fn narrow(&mut self, i: usize, narrow: impl FnOnce(&mut Closest)) {
        let mut c = Closest {
            t: self.t[i],
            prim: self.prim[i],
            u: self.u[i],
            v: self.v[i],
        };
        narrow(&mut c);
        (self.t[i], self.prim[i], self.u[i], self.v[i]) = (c.t, c.prim, c.u, c.v);
    }
}

/// Work counters: one ray's, or summed over a packet's rays.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Work {
    pub nodes: u32,
    pub prims: u32,
    /// A [`FAST`] walk met a sliver it could not judge (see
    /// [`group_closest`]): the ray is to be walked again, [`CAREFUL`]ly.
    pub unsure: bool,
}

impl Work {
    /// Runs `walk` (a second walk of the same ray, or brute force) on
    /// counters of its own and adds them to these: handing these
    /// counters themselves to a call kept them in memory through the
    /// first walk's loop (CBbunny's diffuse rays −16%, PERF.md, BVH,
    /// session of 2026-11-28).
    #[inline(always)]
    pub fn walk_again<T>(&mut self, walk: impl FnOnce(&mut Work) -> T) -> T {
        let mut again = Work::default();
        let result = walk(&mut again);
        self.nodes += again.nodes;
        self.prims += again.prims;
        result
    }
}

/// How a walk treats hits on slivers ([`TriGroup::slivers`]), the `WALK`
/// parameter of the traversals: in a scene without slivers, the
/// triangle test's own distances as they are.
pub(crate) const PLAIN: u8 = 0;
/// In a scene with slivers: hits on them are set aside and the ray
/// flagged ([`Work::unsure`]), to be walked again [`CAREFUL`]ly. The
/// check costs a few instructions per hit, where confirming in place
/// (an out-of-line call in the walk's loop, even never taken) made the
/// whole walk slower.
pub(crate) const FAST: u8 = 1;
/// Hits on slivers are confirmed in place ([`confirm`]).
pub(crate) const CAREFUL: u8 = 2;

/// Traversal stack entry: a child and the distance at which the ray enters it.
#[derive(Clone, Copy, Default)]
pub(crate) struct Entry {
    child: u32,
    t: f32,
}

pub(crate) type Stack = [Entry; STACK_SIZE];

pub(crate) fn new_stack() -> Stack {
    [Entry::default(); STACK_SIZE]
}

/// Tests a ray against a triangle leaf, narrowing `best`.
#[inline(always)]
fn leaf_triangles<const WALK: u8>(
    groups: &[TriGroup],
    tri: &RayTri,
    best: &mut Closest,
    work: &mut Work,
) {
    for g in groups {
        work.prims += g.len();
        if group_closest::<WALK>(g, tri, best) {
            work.unsure = true;
        }
    }
}

/// The far end of the triangle test for group `g` in a walk that checks
/// slivers: `t_far`, or, where the group holds a sliver, +∞, so that
/// every hit on it is seen: its f32 distance may lie beyond `t_far`
/// while its true one does not, and which hits a walk met first must not
/// decide whether it is seen (`triangle::confirm`).
#[inline(always)]
fn sliver_range(g: &TriGroup, t_far: f32) -> f32 {
    if g.slivers() != 0 {
        f32::INFINITY
    } else {
        t_far
    }
}

/// Tests a ray against the triangles of one group, narrowing `best`.
/// Returns whether hits on slivers were set aside ([`FAST`] walks).
#[inline(always)]
fn group_closest<const WALK: u8>(g: &TriGroup, tri: &RayTri, best: &mut Closest) -> bool {
    let t_far = if WALK == PLAIN {
        best.t
    } else {
        sliver_range(g, best.t)
    };
    let mut h = intersect_group(g, tri, t_far);
    if h.mask == 0 {
        return false;
    }
    let set_aside = match WALK {
        PLAIN => 0,
        FAST => {
            let slivers = g.slivers() & h.mask;
            h.mask &= !slivers;
            slivers
        }
        _ => {
            confirm::<false>(g, tri, &mut h, best.t);
            0
        }
    };
    let t = h.t.to_array();
    for lane in crate::lanes::each(h.mask) {
        best.offer(t[lane], g.id(lane), &h, lane);
    }
    set_aside != 0
}

/// Tests a ray against a sphere leaf, narrowing `best`.
#[inline(always)]
fn leaf_spheres(spheres: &[PackedSphere], o: Vec3, d: Vec3, best: &mut Closest, work: &mut Work) {
    for s in spheres {
        work.prims += 1;
        if let Some(t) = intersect_sphere(s, o, d, best.t)
            && (t < best.t || s.id < best.prim)
        {
            *best = Closest {
                t,
                prim: s.id,
                u: 0.0,
                v: 0.0,
            };
        }
    }
}

impl Scene<'_> {
    /// Requests the lines of node or leaf `child` (a leaf's first group).
    #[inline(always)]
    pub fn prefetch_child(&self, child: ChildRef) {
        if !child.is_leaf() {
            prefetch_all(&self.nodes[child.index()]);
        } else if !child.is_sphere() {
            prefetch_all(&self.tri_groups[child.index()]);
        }
    }

    /// Tests one ray against the primitives of `leaf`, narrowing `best`.
    /// `tri` is the ray's triangle-test setup; `WALK` as for
    /// [`group_closest`].
    #[inline(always)]
    pub fn leaf_closest<const WALK: u8>(
        &self,
        leaf: ChildRef,
        (o, d): (Vec3, Vec3),
        tri: &RayTri,
        best: &mut Closest,
        work: &mut Work,
    ) {
        if leaf.is_sphere() {
            self.leaf_closest_spheres(leaf, (o, d), best, work);
        } else {
            let items = leaf.index()..leaf.index() + leaf.count();
            leaf_triangles::<WALK>(&self.tri_groups[items], tri, best, work);
        }
    }

    /// [`leaf_closest`](Self::leaf_closest) for a sphere leaf.
    #[inline(always)]
    pub fn leaf_closest_spheres(
        &self,
        leaf: ChildRef,
        (o, d): (Vec3, Vec3),
        best: &mut Closest,
        work: &mut Work,
    ) {
        let items = leaf.index()..leaf.index() + leaf.count();
        leaf_spheres(&self.spheres[items], o, d, best, work);
    }

    /// Tests the rays `rays` of one batch slot of a packet against the
    /// triangle leaf `leaf`, narrowing each ray's `best` (the slot's rays
    /// are lanes `WIDTH · slot..` of it); `tri` is their
    /// triangle-test setup. When the rays share one permutation
    /// ([`PacketTri::Shared`]) and outnumber a group's triangles, the group
    /// is tested triangle by triangle against all rays at once (lanes =
    /// rays), else ray by ray (lanes = triangles); each (ray, triangle)
    /// pair computes the same values either way. `WALK` as for
    /// [`group_closest`]: a fast walk sets `work.unsure` for the packet.
    #[inline(never)]
    pub fn leaf_closest_packet<const WALK: u8>(
        &self,
        leaf: ChildRef,
        rays: u32,
        tri: &PacketTri,
        (best, slot): (&mut ClosestLanes, usize),
        work: &mut Work,
    ) {
        let n_rays = rays.count_ones();
        let first = WIDTH * slot;
        for g in &self.tri_groups[leaf.index()..leaf.index() + leaf.count()] {
            let len = g.len();
            work.prims += len * n_rays;
            match tri {
                PacketTri::Shared(packet) if n_rays > len => {
                    let mut t_best = best.t_slot(slot);
                    for lane in 0..len as usize {
                        let sliver = WALK != PLAIN && g.slivers() & (1 << lane) != 0;
                        let t_far = if sliver {
                            Lanes::splat(f32::INFINITY)
                        } else {
                            t_best
                        };
                        let mut h = intersect_rays(g, lane, packet, t_far);
                        h.mask &= rays;
                        if h.mask == 0 {
                            continue;
                        }
                        match WALK {
                            PLAIN => {}
                            FAST => {
                                if sliver {
                                    work.unsure = true;
                                    continue;
                                }
                            }
                            _ => {
                                if confirm_rays(g, lane, packet, &mut h, t_best) == 0 {
                                    continue;
                                }
                            }
                        }
                        let hit = h.mask;
                        let t = h.t.to_array();
                        for i in crate::lanes::each(hit) {
                            best.narrow(first + i, |c| c.offer(t[i], g.id(lane), &h, i));
                        }
                        t_best = best.t_slot(slot);
                    }
                }
                _ => {
                    for i in crate::lanes::each(rays) {
                        let mut unsure = false;
                        best.narrow(first + i, |c| {
                            unsure = group_closest::<WALK>(g, &tri.ray(i), c);
                        });
                        work.unsure |= unsure;
                    }
                }
            }
        }
    }

    /// Whether one ray hits any primitive of `leaf` within `[0, t_max]`
    /// (stops at the first); `tri` as for [`leaf_closest`](Self::leaf_closest).
    #[inline(always)]
    pub fn leaf_occludes<const WALK: u8>(
        &self,
        leaf: ChildRef,
        (o, d, t_max): (Vec3, Vec3, f32),
        tri: &RayTri,
        work: &mut Work,
    ) -> bool {
        let items = leaf.index()..leaf.index() + leaf.count();
        if leaf.is_sphere() {
            spheres_occlude(&self.spheres[items], o, d, t_max, work)
        } else {
            triangles_occlude::<WALK>(&self.tri_groups[items], tri, t_max, work)
        }
    }
}

/// Whether the ray hits any triangle of `groups` within `[0, t_max]`.
/// A [`FAST`] walk does not judge hits on slivers: it sets `work.unsure`
/// instead, as [`group_closest`] does.
#[inline(always)]
fn triangles_occlude<const WALK: u8>(
    groups: &[TriGroup],
    tri: &RayTri,
    t_max: f32,
    work: &mut Work,
) -> bool {
    for g in groups {
        work.prims += g.len();
        let t_test = if WALK == PLAIN {
            t_max
        } else {
            sliver_range(g, t_max)
        };
        let mut h = intersect_group(g, tri, t_test);
        if h.mask == 0 {
            continue;
        }
        match WALK {
            PLAIN => return true,
            FAST => {
                let slivers = g.slivers();
                let within = h.t.simd_le(Lanes::splat(t_max)).to_bitmask();
                if h.mask & !slivers & within != 0 {
                    return true;
                }
                if h.mask & slivers != 0 {
                    work.unsure = true;
                }
            }
            _ => {
                if confirm::<true>(g, tri, &mut h, t_max) != 0 {
                    return true;
                }
            }
        }
    }
    false
}

/// Whether the ray hits any of `spheres` within `[0, t_max]`.
#[inline(always)]
fn spheres_occlude(
    spheres: &[PackedSphere],
    o: Vec3,
    d: Vec3,
    t_max: f32,
    work: &mut Work,
) -> bool {
    for s in spheres {
        work.prims += 1;
        if intersect_sphere(s, o, d, t_max).is_some() {
            return true;
        }
    }
    false
}

/// Sorts the children of `node` hit by the ray (`mask`, entry distances
/// `t_enter`) by distance, pushes all but the nearest far-to-near and
/// returns the nearest. Most nodes are entered with one or two children
/// hit, which take a short path; more are ranked in SIMD lanes. Equal
/// distances are visited in descending slot order on every path. The
/// distances of hit children are never NaN (the slab test's entry
/// distance starts at 0 and ignores NaN candidates), which the ranking
/// relies on: a NaN would compare unequal to itself and share a place.
#[inline(always)]
fn push_children(
    node: &WideNode,
    mask: u32,
    t_enter: Lanes,
    stack: &mut Stack,
    sp: &mut usize,
) -> ChildRef {
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest == 0 {
        return node.child[first];
    }
    let te = t_enter.to_array();
    if rest & (rest - 1) == 0 {
        let second = rest.trailing_zeros() as usize;
        let (near, far) = if te[first] < te[second] {
            (first, second)
        } else {
            (second, first)
        };
        stack[*sp] = Entry {
            child: node.child[far].0,
            t: te[far],
        };
        *sp += 1;
        return node.child[near];
    }
    // Three or more: each child's place in far-to-near order is the
    // number of children ahead of it (farther, or as far and in a lower
    // slot), counted for all slots at once. Missed slots count as −∞, so
    // they rank after every hit one and land above the new top of stack
    // (the stack has room for all WIDTH). An insertion sort here branched
    // on the data and mispredicted; this measured 2–3% faster on diffuse
    // rays (PERF.md).
    const { assert!(WIDTH == 8) };
    let n = mask.count_ones() as usize;
    let hit = crate::lanes::lane_mask(mask);
    let t = hit.select(t_enter, Lanes::splat(f32::NEG_INFINITY));
    let slot = i32x8::from([0, 1, 2, 3, 4, 5, 6, 7]);
    let mut place = i32x8::ZERO;
    for j in 0..WIDTH {
        let tj = Lanes::splat(t.as_array()[j]);
        let lower_slot = from_bits(slot.simd_gt(i32x8::splat(j as i32)));
        let ahead = tj.simd_gt(t) | (tj.simd_eq(t) & lower_slot);
        // All-ones lanes are −1 as integers.
        place -= to_bits(ahead);
    }
    let place = place.to_array();
    for (s, &p) in place.iter().enumerate() {
        stack[*sp + (p as usize & (WIDTH - 1))] = Entry {
            child: node.child[s].0,
            t: te[s],
        };
    }
    let nearest = ChildRef(stack[*sp + n - 1].child);
    *sp += n - 1;
    nearest
}

/// Pushes the children of `node` in `mask` except the first, which it
/// returns: any-hit order, no sorting.
#[inline(always)]
fn push_unordered(node: &WideNode, mask: u32, stack: &mut Stack, sp: &mut usize) -> ChildRef {
    let mut rest = mask & (mask - 1);
    while rest != 0 {
        let slot = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        stack[*sp] = Entry {
            child: node.child[slot].0,
            t: 0.0,
        };
        *sp += 1;
    }
    node.child[mask.trailing_zeros() as usize]
}

/// Closest hit along `o + t·d`, `t ∈ [0, t_max]`, for the ray in `lane`
/// of a batch cull that let it through (its bit is set in `cull.mask`,
/// so the ray can hit something: see [`never_hits`]).
#[inline(always)]
pub(crate) fn closest<const WALK: u8>(
    scene: &Scene,
    stack: &mut Stack,
    (cull, lane): (&Cull, usize),
    (o, d, t_max): (Vec3, Vec3, f32),
    work: &mut Work,
) -> Closest {
    let mut best = Closest::none(t_max);
    // The batch cull keeps such rays out.
    debug_assert!(!never_hits(o, d, t_max) && cull.mask & (1 << lane) != 0);
    let rb = cull.ray_box(lane, o);
    let tri = cull.ray_tri(lane, o);
    let mut sp = 0usize;
    // Pops the next child that is not farther than the nearest hit so far.
    let pop = |stack: &Stack, sp: &mut usize, t_best: f32| {
        while *sp > 0 {
            *sp -= 1;
            let e = stack[*sp];
            if e.t <= rb.cull(t_best) {
                return Some(ChildRef(e.child));
            }
        }
        None
    };
    let mut current = scene.root;
    loop {
        // Inner nodes in a loop of their own ("while-while", Aila and
        // Laine 2009), apart from the leaf test: it measured ~1% fewer
        // instructions on incoherent rays.
        while !current.is_leaf() {
            let node = &scene.nodes[current.index()];
            work.nodes += 1;
            let (mask, t_enter) = rb.test(node, best.t);
            current = if mask != 0 {
                push_children(node, mask, t_enter, stack, &mut sp)
            } else {
                match pop(stack, &mut sp, best.t) {
                    Some(c) => c,
                    None => return best,
                }
            };
        }
        // The entry on top of the stack is most often the next visited:
        // its lines arrive while this leaf is tested.
        if sp > 0 {
            scene.prefetch_child(ChildRef(stack[sp - 1].child));
        }
        scene.leaf_closest::<WALK>(current, (o, d), &tri, &mut best, work);
        match pop(stack, &mut sp, best.t) {
            Some(c) => current = c,
            None => return best,
        }
    }
}

/// Whether anything is hit along `o + t·d`, `t ∈ [0, t_max]`, for the ray
/// in `lane` of a batch cull that let it through (as for [`closest`]).
#[inline(always)]
pub(crate) fn any<const WALK: u8>(
    scene: &Scene,
    stack: &mut Stack,
    (cull, lane): (&Cull, usize),
    (o, d, t_max): (Vec3, Vec3, f32),
    work: &mut Work,
) -> bool {
    // The batch cull keeps such rays out.
    debug_assert!(!never_hits(o, d, t_max) && cull.mask & (1 << lane) != 0);
    let rb = cull.ray_box(lane, o);
    let tri = cull.ray_tri(lane, o);
    let mut sp = 0usize;
    let mut current = scene.root;
    // Children are visited in slot order, unsorted: any occluder ends the
    // search, and sorting cost more than it saved on shadow rays.
    loop {
        if !current.is_leaf() {
            let node = &scene.nodes[current.index()];
            work.nodes += 1;
            let (mask, _) = rb.test(node, t_max);
            if mask != 0 {
                current = push_unordered(node, mask, stack, &mut sp);
                continue;
            }
        } else if scene.leaf_occludes::<WALK>(current, (o, d, t_max), &tri, work) {
            return true;
        }
        if sp == 0 {
            return false;
        }
        sp -= 1;
        current = ChildRef(stack[sp].child);
    }
}

/// [`closest`] walked carefully, for a ray whose fast walk met slivers
/// ([`group_closest`]). Out of line: inlined beside the fast walk, it
/// slowed that walk down.
#[cold]
#[inline(never)]
pub(crate) fn closest_careful(
    scene: &Scene,
    stack: &mut Stack,
    lane: (&Cull, usize),
    ray: (Vec3, Vec3, f32),
    work: &mut Work,
) -> Closest {
    closest::<{ CAREFUL }>(scene, stack, lane, ray, work)
}

/// [`any`] walked carefully, as [`closest_careful`].
#[cold]
#[inline(never)]
pub(crate) fn any_careful(
    scene: &Scene,
    stack: &mut Stack,
    lane: (&Cull, usize),
    ray: (Vec3, Vec3, f32),
    work: &mut Work,
) -> bool {
    any::<{ CAREFUL }>(scene, stack, lane, ray, work)
}

/// Brute force closest hit: every primitive, no hierarchy, hits on
/// slivers confirmed in place. Out of line, beside the walks that use a
/// hierarchy.
#[inline(never)]
pub(crate) fn closest_brute(
    groups: &[TriGroup],
    spheres: &[PackedSphere],
    (o, d, t_max): (Vec3, Vec3, f32),
    work: &mut Work,
) -> Closest {
    let mut best = Closest::none(t_max);
    if never_hits(o, d, t_max) {
        return best;
    }
    let tri = RayTri::new(o, d);
    leaf_triangles::<{ CAREFUL }>(groups, &tri, &mut best, work);
    leaf_spheres(spheres, o, d, &mut best, work);
    best
}

/// Brute force any hit, as [`closest_brute`].
#[inline(never)]
pub(crate) fn any_brute(
    groups: &[TriGroup],
    spheres: &[PackedSphere],
    (o, d, t_max): (Vec3, Vec3, f32),
    work: &mut Work,
) -> bool {
    if never_hits(o, d, t_max) {
        return false;
    }
    triangles_occlude::<{ CAREFUL }>(groups, &RayTri::new(o, d), t_max, work)
        || spheres_occlude(spheres, o, d, t_max, work)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every set of hit children, with distinct and tied distances: the
    /// nearest is returned and the rest are pushed far to near (ties in
    /// ascending slot order, so they are popped, and visited, in
    /// ascending distance and descending slot), nothing lost or
    /// duplicated, and what was on the stack before left alone.
    #[test]
    fn children_are_pushed_far_to_near() {
        let child = std::array::from_fn(|s| ChildRef::node(100 + s as u32));
        let node = WideNode {
            bounds: [[Lanes::ZERO; 2]; 3],
            child,
        };
        let distances: [[f32; WIDTH]; 3] = [
            [5.0, 1.0, 7.0, 3.0, 0.0, 6.0, 2.0, 4.0],
            [2.0, 2.0, 1.0, 2.0, 0.5, 1.0, 2.0, 0.0],
            [0.0; WIDTH],
        ];
        for t in distances {
            for mask in 1u32..(1 << WIDTH) {
                let mut stack = new_stack();
                let below = Entry {
                    child: 999,
                    t: -1.0,
                };
                stack[..3].fill(below);
                let mut sp = 3;
                let nearest = push_children(&node, mask, Lanes::from(t), &mut stack, &mut sp);
                // Visit order: the returned child, then pops from the top.
                let mut visited = vec![nearest.0 - 100];
                visited.extend(stack[3..sp].iter().rev().map(|e| e.child - 100));
                let mut expected: Vec<u32> = (0..WIDTH as u32)
                    .filter(|&s| mask & (1 << s) != 0)
                    .collect();
                expected.sort_by(|&a, &b| {
                    let (ta, tb) = (t[a as usize], t[b as usize]);
                    ta.total_cmp(&tb).then(b.cmp(&a))
                });
                assert_eq!(visited, expected, "mask {mask:08b}, t {t:?}");
                for e in &stack[3..sp] {
                    assert_eq!(e.t, t[e.child as usize - 100]);
                }
                assert!(stack[..3].iter().all(|e| e.child == 999 && e.t == -1.0));
            }
        }
    }
}
