//! Packet traversal for closest-hit queries: the rays of one batch slot
//! ([`WIDTH`]) or of two (sixteen, in AVX-512 registers) walk the tree
//! together, one SIMD lane per ray. The code is generic over the register
//! ([`RayLanes`]); leaves are handled per slot.
//!
//! Single-ray traversal tests one ray against a node's [`WIDTH`] child
//! boxes at once; most of its cost per node is not that test but the
//! control around it (sorting the children hit, the stack, the branches).
//! Rays that travel together — the samples of one pixel — visit nearly the
//! same nodes, so here that control is paid once per node for the whole
//! packet: each child box is tested
//! against all rays at once (lanes = rays), the children hit by any active
//! ray are visited nearest first along the packet's leading ray, and each
//! stack entry carries the mask of rays that entered it and their entry
//! distances. At a triangle leaf, when the rays share one permutation of
//! the watertight test (the same major axis and sign, as coherent rays
//! do) and outnumber a group's triangles, each triangle is tested against
//! all rays at once (lanes = rays); otherwise each ray runs the
//! single-ray group test (lanes = triangles). Either way every (ray,
//! triangle) pair computes the same values.
//!
//! The box test is the same arithmetic as [`RayBox`](super::traverse)'s, lane
//! by lane (same operations, same order, same conservative margins), and
//! closest hits break exact ties by primitive id, so a ray's result does not
//! depend on whether it was traced alone or in a packet, nor with whom.
//!
//! Packets are used only when all their rays point into the same octant,
//! so one choice of near and far planes per axis serves every lane (the
//! caller falls back to one-slot packets when two slots disagree, to single
//! rays when one slot's rays do, and to single rays for the per-ray cost
//! counters of `--shading bvh-cost`).

use std::ops::{Add, Mul, Sub};

use glam::Vec3;

use super::flatten::{ChildRef, WideNode};
use super::traverse::{CAREFUL, ClosestLanes, Cull, Ray8Src, Scene, T_FAR_MARGIN, Work, slab_test};
use super::triangle::PacketTri;
use super::{Lanes, WIDTH};
use crate::lanes::per_axis;

/// Batch slots (of [`WIDTH`] rays) in the widest packet.
pub(crate) const MAX_SLOTS: usize = 2;
/// Rays in the widest packet.
pub(crate) const MAX_RAYS: usize = MAX_SLOTS * WIDTH;

/// A SIMD register with one lane per ray of a packet: [`Lanes`] for the
/// rays of one batch slot, `wide::f32x16` for two (one AVX-512 register
/// on this project's target). Every operation works lane by lane the same
/// way in both, so a ray's lane computes the same bits in either: the
/// arithmetic is IEEE, and `fast_max`/`fast_min` are the x86 `maxps`/
/// `minps` (a NaN in either operand gives the second one), on which the
/// slab test's treatment of NaN relies.
pub(crate) trait RayLanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self>
{
    /// Batch slots per register.
    const SLOTS: usize;
    fn splat(x: f32) -> Self;
    /// The registers `slot(0)`, `slot(1)`, … of consecutive batch slots
    /// side by side (only as many as the register holds are asked for).
    fn from_slots(slot: impl Fn(usize) -> Lanes) -> Self;
    fn fast_max(self, other: Self) -> Self;
    fn fast_min(self, other: Self) -> Self;
    /// All-ones lanes where `self <= other`.
    fn le(self, other: Self) -> Self;
    fn bitmask(self) -> u32;
    /// The value in lane `i`.
    fn lane(self, i: usize) -> f32;
}

/// Implements [`RayLanes`] for `$t` (`$slots` batch slots, assembled from
/// the slots' registers `$s(0)`, … by `$from`) by forwarding to `wide`'s
/// methods.
macro_rules! ray_lanes {
    ($t:ty, $slots:expr, |$s:ident| $from:expr) => {
        impl RayLanes for $t {
            const SLOTS: usize = $slots;
            #[inline(always)]
            fn splat(x: f32) -> Self {
                <$t>::splat(x)
            }
            #[inline(always)]
            fn from_slots($s: impl Fn(usize) -> Lanes) -> Self {
                $from
            }
            #[inline(always)]
            fn fast_max(self, other: Self) -> Self {
                <$t>::fast_max(self, other)
            }
            #[inline(always)]
            fn fast_min(self, other: Self) -> Self {
                <$t>::fast_min(self, other)
            }
            #[inline(always)]
            fn le(self, other: Self) -> Self {
                self.simd_le(other)
            }
            #[inline(always)]
            fn bitmask(self) -> u32 {
                self.to_bitmask()
            }
            #[inline(always)]
            fn lane(self, i: usize) -> f32 {
                self.as_array()[i]
            }
        }
    };
}

ray_lanes!(Lanes, 1, |slot| slot(0));
ray_lanes!(wide::f32x16, 2, |slot| {
    let (a, b) = (slot(0).to_array(), slot(1).to_array());
    wide::f32x16::from(std::array::from_fn::<f32, 16, _>(|i| {
        if i < WIDTH { a[i] } else { b[i - WIDTH] }
    }))
});

/// Stack entry: a child, the rays that entered it and where they did.
#[derive(Clone, Copy)]
pub(crate) struct PacketEntry<L> {
    child: u32,
    mask: u32,
    t_enter: L,
}

/// Traversal stack of a packet (reused across the packets of a batch). It
/// grows as needed, so creating one initialises nothing.
pub(crate) type PacketStack<L> = Vec<PacketEntry<L>>;

pub(crate) fn new_packet_stack<L>() -> PacketStack<L> {
    Vec::with_capacity(64)
}

/// The packet's rays, lane-wise, with the per-ray constants of the slab
/// test. Inactive lanes hold whatever the batch has there (or zeros past
/// its end) and are masked out everywhere.
pub(crate) struct Packet<L> {
    o: [L; 3],
    /// Directions: the leading ray's orders the children; all are read
    /// by the leaf tests of spheres (rare).
    d: [L; 3],
    inv: [L; 3],
    /// Near plane per axis (0 = min corner), shared by every lane.
    near: [usize; 3],
    /// Absolute cull slack per lane (see `traverse::SLACK_ULPS`).
    slack: L,
    /// Direction of the first active ray: orders the children.
    lead: Vec3,
    /// Triangle-test setup of the rays, per batch slot.
    tri: [PacketTri; MAX_SLOTS],
}

impl<L: RayLanes> Packet<L> {
    /// Gathers the rays of the `L::SLOTS` batch slots from `start` that
    /// their batch culls (`slots`, one per slot) let through into a
    /// packet, with the mask of those rays (slot `s` in bits `8s..`), or
    /// `None` if their directions do not all lie in one octant. The culls'
    /// reciprocal directions and slacks are the packet's, so packet and
    /// single-ray box decisions agree exactly.
    #[inline(always)]
    pub fn new(rays: &Ray8Src, start: usize, slots: &[&Cull]) -> Option<(Self, u32)> {
        debug_assert_eq!(slots.len(), L::SLOTS);
        let active = slots
            .iter()
            .enumerate()
            .fold(0, |m, (s, c)| m | c.mask << (WIDTH * s));
        // The sign of 1/d (±∞ for ±0) picks the near plane, as in RayBox.
        let mut near = [0usize; 3];
        for (axis, near) in near.iter_mut().enumerate() {
            let negative = slots.iter().enumerate().fold(0, |m, (s, c)| {
                m | (c.negative(axis) & c.mask) << (WIDTH * s)
            });
            *near = if negative == 0 {
                0
            } else if negative == active {
                1
            } else {
                return None;
            };
        }
        let mut o_slots = [[Lanes::ZERO; 3]; MAX_SLOTS];
        let mut d_slots = [[Lanes::ZERO; 3]; MAX_SLOTS];
        let mut tri = [PacketTri::default(); MAX_SLOTS];
        for (s, cull) in slots.iter().enumerate() {
            let (o, d) = rays.lanes(start + WIDTH * s);
            tri[s] = cull.packet_tri(cull.mask, &o);
            (o_slots[s], d_slots[s]) = (o, d);
        }
        debug_assert!(active != 0, "a packet has at least one ray");
        let d = per_axis(|axis| L::from_slots(|s| d_slots[s][axis]));
        let packet = Packet {
            o: per_axis(|axis| L::from_slots(|s| o_slots[s][axis])),
            d,
            inv: per_axis(|axis| L::from_slots(|s| slots[s].inv()[axis])),
            near,
            slack: L::from_slots(|s| slots[s].slack()),
            lead: lane_vec(&d, active.trailing_zeros() as usize),
            tri,
        };
        Some((packet, active))
    }

    /// Origin and direction of the ray in lane `i`.
    #[inline(always)]
    fn ray(&self, i: usize) -> (Vec3, Vec3) {
        (lane_vec(&self.o, i), lane_vec(&self.d, i))
    }

    /// Cull distance per lane for the current far ends `t_far`.
    #[inline(always)]
    fn cull(&self, t_far: L) -> L {
        t_far * L::splat(T_FAR_MARGIN) + self.slack
    }

    /// Tests child `slot` of `node` against every lane; returns the lanes
    /// (within `mask`) that enter it and their entry distances.
    #[inline(always)]
    fn test(&self, node: &WideNode, slot: usize, cull: L, mask: u32) -> (u32, L) {
        let b = &node.bounds;
        let n = self.near;
        let plane = |side: usize, axis: usize| L::splat(b[axis][side].as_array()[slot]);
        let (m, t_enter) = slab_test(
            per_axis(|a| plane(n[a], a)),
            per_axis(|a| plane(1 - n[a], a)),
            &self.o,
            &self.inv,
            cull,
        );
        (m.bitmask() & mask, t_enter)
    }

    /// The far ends of the packet's rays: each one's nearest hit so far.
    #[inline(always)]
    fn t_best(best: &ClosestLanes) -> L {
        L::from_slots(|s| best.t_slot(s))
    }
}

/// Lane `i` of a vector held lane-wise.
#[inline(always)]
fn lane_vec<L: RayLanes>(v: &[L; 3], i: usize) -> Vec3 {
    Vec3::new(v[0].lane(i), v[1].lane(i), v[2].lane(i))
}

/// The slots of `node` that hold a child (empty ones have +∞ minimum corners).
#[inline(always)]
fn occupied(node: &WideNode) -> u32 {
    node.bounds[0][0]
        .simd_lt(Lanes::splat(f32::INFINITY))
        .to_bitmask()
}

/// Visits the children of `node` entered by rays of `mask`: pushes the far
/// ones and returns the nearest (along the leading ray), or `None` if no
/// ray enters any child.
#[inline(always)]
fn descend<L: RayLanes>(
    packet: &Packet<L>,
    node: &WideNode,
    mask: u32,
    cull: L,
    stack: &mut PacketStack<L>,
) -> Option<(ChildRef, u32)> {
    let mut slots = occupied(node);
    // Order key: the box centre (doubled) along the leading direction.
    let l = packet.lead;
    let [x, y, z] = &node.bounds;
    let key = (x[0] + x[1]) * Lanes::splat(l.x)
        + (y[0] + y[1]) * Lanes::splat(l.y)
        + (z[0] + z[1]) * Lanes::splat(l.z);
    let key = key.as_array();
    let mut masks = [0u32; WIDTH];
    let mut t_enter = [L::splat(0.0); WIDTH];
    // Every child's test first, without a branch on its outcome (about
    // four in five tested boxes are entered by no ray, in no predictable
    // pattern), then the slots entered.
    let mut entered = 0u32;
    while slots != 0 {
        let slot = slots.trailing_zeros() as usize;
        slots &= slots - 1;
        let (m, t) = packet.test(node, slot, cull, mask);
        masks[slot] = m;
        t_enter[slot] = t;
        entered |= u32::from(m != 0) << slot;
    }
    // Slots entered, insertion-sorted far to near.
    let mut order = [0usize; WIDTH];
    let mut n = 0;
    while entered != 0 {
        let slot = entered.trailing_zeros() as usize;
        entered &= entered - 1;
        let mut j = n;
        while j > 0 && key[order[j - 1]] < key[slot] {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = slot;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    for &slot in &order[..n - 1] {
        stack.push(PacketEntry {
            child: node.child[slot].0,
            mask: masks[slot],
            t_enter: t_enter[slot],
        });
    }
    let nearest = order[n - 1];
    Some((node.child[nearest], masks[nearest]))
}

/// Closest hits of the packet's `active` rays. `best` holds each lane's
/// initial `t_max` (and no hit) and receives the results; `work` the
/// primitives tested and `visits` the node visits, both summed over rays.
/// `WALK` as for `traverse::group_closest`: a [`FAST`] walk that meets
/// slivers sets `work.unsure`, and the packet is to be walked again
/// ([`closest_careful`]).
#[inline(always)]
pub(crate) fn closest<L: RayLanes, const WALK: u8>(
    scene: &Scene,
    stack: &mut PacketStack<L>,
    packet: &Packet<L>,
    active: u32,
    best: &mut ClosestLanes,
    work: &mut Work,
    visits: &mut u64,
) {
    // Cull distances for the rays' nearest hits so far (they change only
    // at leaves).
    let mut cull = packet.cull(Packet::<L>::t_best(best));
    stack.clear();
    let mut current = (scene.root, active);
    loop {
        let (child, mask) = current;
        if !child.is_leaf() {
            let node = &scene.nodes[child.index()];
            *visits += u64::from(mask.count_ones());
            if let Some(next) = descend(packet, node, mask, cull, stack) {
                current = next;
                continue;
            }
        } else {
            if child.is_sphere() {
                for i in crate::lanes::each(mask) {
                    let ray = packet.ray(i);
                    best.narrow(i, |c| scene.leaf_closest_spheres(child, ray, c, work));
                }
            } else {
                for s in 0..L::SLOTS {
                    let rays = (mask >> (WIDTH * s)) & 0xff;
                    if rays != 0 {
                        let tri = &packet.tri[s];
                        scene.leaf_closest_packet::<WALK>(child, rays, tri, (best, s), work);
                    }
                }
            }
            cull = packet.cull(Packet::<L>::t_best(best));
        }
        // Pop the next entry some ray still needs: entered no farther than
        // that ray's nearest hit so far.
        loop {
            let Some(e) = stack.pop() else {
                return;
            };
            let m = e.mask & e.t_enter.le(cull).bitmask();
            if m != 0 {
                current = (ChildRef(e.child), m);
                break;
            }
        }
    }
}

/// [`closest`] walked carefully, after a fast walk met slivers. Out of
/// line, so that the fast walk's code stays as it was.
#[cold]
#[inline(never)]
pub(crate) fn closest_careful<L: RayLanes>(
    scene: &Scene,
    stack: &mut PacketStack<L>,
    packet: &Packet<L>,
    active: u32,
    best: &mut ClosestLanes,
    work: &mut Work,
    visits: &mut u64,
) {
    closest::<L, { CAREFUL }>(scene, stack, packet, active, best, work, visits);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::traverse::may_hit;
    use crate::sampling::rng::{hash32, to_unit_float};

    /// One node's step of a packet: the children some ray enters are
    /// visited nearest first by box centre along the leading ray (exact
    /// ties: higher slot first, as the single-ray walk breaks them), the
    /// nearest returned and the rest pushed above what the stack held;
    /// each carries exactly the rays whose own slab test (the single-ray
    /// one, with its cull at the ray's `t_max`) enters it, at the entry
    /// distances that test gives.
    #[test]
    fn descend_orders_by_centre_and_agrees_with_single_rays() {
        let mut draw = 0;
        let mut next = move || {
            draw += 1;
            to_unit_float(hash32(draw))
        };
        for trial in 0..300u32 {
            let sign = Vec3::from([1, 2, 4].map(|b| if trial & b == 0 { 1.0 } else { -1.0 }));
            let axis_dir = Vec3::new(0.2 + next(), 0.2 + next(), 0.2 + next()).normalize() * sign;
            let mut org = [[0.0f32; WIDTH]; 3];
            let mut dir = [[0.0f32; WIDTH]; 3];
            let mut t_max = [f32::INFINITY; WIDTH];
            for lane in 0..WIDTH {
                let o = Vec3::new(next(), next(), next()) - 0.5;
                let d = axis_dir + (Vec3::new(next(), next(), next()) - 0.5) * 0.2;
                for a in 0..3 {
                    org[a][lane] = o[a];
                    dir[a][lane] = d[a];
                }
                if next() < 0.4 {
                    t_max[lane] = 6.0 + next() * 8.0;
                }
            }
            // Boxes 6 to 14 along the rays, up to 2 aside: some entered by
            // every ray, some by a few, some by none, some slots empty.
            let mut lo = [[f32::INFINITY; WIDTH]; 3];
            let mut hi = [[f32::NEG_INFINITY; WIDTH]; 3];
            for slot in 0..WIDTH {
                if next() < 0.15 {
                    continue;
                }
                let c = axis_dir * (6.0 + next() * 8.0)
                    + (Vec3::new(next(), next(), next()) - 0.5) * 4.0;
                let h = Vec3::new(next(), next(), next()) * 2.5 + 0.3;
                for a in 0..3 {
                    (lo[a][slot], hi[a][slot]) = (c[a] - h[a], c[a] + h[a]);
                }
            }
            if trial % 3 == 0 {
                // An exact tie of keys (the same box twice).
                for a in 0..3 {
                    (lo[a][6], hi[a][6]) = (lo[a][2], hi[a][2]);
                }
            }
            let node = WideNode {
                bounds: [0, 1, 2].map(|a| [Lanes::from(lo[a]), Lanes::from(hi[a])]),
                child: std::array::from_fn(|s| ChildRef::node(100 + s as u32)),
            };
            let src = Ray8Src {
                org: org.each_ref().map(|v| &v[..]),
                dir: dir.each_ref().map(|v| &v[..]),
                t_max: &t_max,
            };
            let scene_box = [[-30.0; 3], [30.0; 3]];
            let batch_cull = may_hit(&scene_box, 30.0, &src, 0);
            assert_eq!(batch_cull.mask, 0xff, "trial {trial}: every ray may hit");
            let (packet, active) =
                Packet::<Lanes>::new(&src, 0, &[&batch_cull]).expect("rays in one octant");
            let cull = packet.cull(Packet::<Lanes>::t_best(&ClosestLanes::none(&t_max)));
            let mut stack = new_packet_stack();
            let below = PacketEntry {
                child: 999,
                mask: 0,
                t_enter: Lanes::ZERO,
            };
            stack.push(below);
            let nearest = descend(&packet, &node, active, cull, &mut stack);

            // Each ray alone.
            let mut rays_in = [0u32; WIDTH];
            let mut t_alone = [[0.0f32; WIDTH]; WIDTH];
            for lane in 0..WIDTH {
                let o = Vec3::new(org[0][lane], org[1][lane], org[2][lane]);
                let (hit, t) = batch_cull.ray_box(lane, o).test_lanes(&node, t_max[lane]);
                for slot in crate::lanes::each(hit.to_bitmask()) {
                    rays_in[slot] |= 1 << lane;
                    t_alone[slot][lane] = t.as_array()[slot];
                }
            }
            let d0 = Vec3::new(dir[0][0], dir[1][0], dir[2][0]);
            let key = |s: usize| {
                (lo[0][s] + hi[0][s]) * d0.x
                    + (lo[1][s] + hi[1][s]) * d0.y
                    + (lo[2][s] + hi[2][s]) * d0.z
            };
            let mut want: Vec<usize> = (0..WIDTH).filter(|&s| rays_in[s] != 0).collect();
            want.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(b.cmp(&a)));

            // Visit order: the returned child, then pops from the top.
            let mut visited: Vec<(usize, u32)> = nearest
                .iter()
                .map(|&(c, m)| (c.0 as usize - 100, m))
                .collect();
            assert_eq!(
                stack[0].child, 999,
                "trial {trial}: the entry below was moved"
            );
            for e in stack[1..].iter().rev() {
                let slot = e.child as usize - 100;
                visited.push((slot, e.mask));
                for lane in crate::lanes::each(e.mask) {
                    let (t, want_t) = (e.t_enter.as_array()[lane], t_alone[slot][lane]);
                    assert_eq!(t.to_bits(), want_t.to_bits(), "trial {trial}, slot {slot}");
                }
            }
            let order: Vec<usize> = visited.iter().map(|v| v.0).collect();
            assert_eq!(order, want, "trial {trial}: visit order");
            for (slot, mask) in visited {
                assert_eq!(mask, rays_in[slot], "trial {trial}, slot {slot}: rays");
            }
        }
    }
}
