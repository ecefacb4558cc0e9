//! Packet traversal for closest-hit queries: [`WIDTH`] rays walk the tree
//! together, one SIMD lane per ray.
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
//! caller falls back to single rays otherwise, and for the per-ray cost
//! counters of `--shading bvh-cost`).

use glam::Vec3;

use super::flatten::{ChildRef, WideNode};
use super::traverse::{Closest, Cull, Ray8Src, Scene, T_FAR_MARGIN, Work, slab_test};
use super::triangle::PacketTri;
use super::{Lanes, WIDTH};
use crate::lanes::Vec3x8;

/// Stack entry: a child, the rays that entered it and where they did.
#[derive(Clone, Copy)]
pub(crate) struct PacketEntry {
    child: u32,
    mask: u32,
    t_enter: Lanes,
}

/// Traversal stack of a packet (reused across the packets of a batch). It
/// grows as needed, so creating one initialises nothing.
pub(crate) type PacketStack = Vec<PacketEntry>;

pub(crate) fn new_packet_stack() -> PacketStack {
    Vec::with_capacity(64)
}

/// The packet's rays, lane-wise, with the per-ray constants of the slab
/// test. Inactive lanes hold whatever the batch has there (or zeros past
/// its end) and are masked out everywhere.
pub(crate) struct Packet {
    o: [Lanes; 3],
    inv: [Lanes; 3],
    /// Near plane per axis (0 = min corner), shared by every lane.
    near: [usize; 3],
    /// Absolute cull slack per lane (see `traverse::SLACK_ULPS`).
    slack: Lanes,
    /// Scalar origin and direction per lane, for the leaf tests.
    org: [Vec3; WIDTH],
    dir: [Vec3; WIDTH],
    /// Direction of the first active ray: orders the children.
    lead: Vec3,
    /// Triangle-test setup of the rays.
    tri: PacketTri,
}

impl Packet {
    /// Gathers the rays `start..start + WIDTH` of `rays` that the batch
    /// cull let through (`cull.mask`) into a packet, or `None` if their
    /// directions do not all lie in one octant. The cull's reciprocal
    /// directions and slacks are the packet's, so packet and single-ray
    /// box decisions agree exactly.
    #[inline(always)]
    pub fn new(rays: &Ray8Src, start: usize, cull: &Cull) -> Option<Packet> {
        let active = cull.mask;
        let inv = cull.inv();
        // The sign of 1/d (±∞ for ±0) picks the near plane, as in RayBox.
        let mut near = [0usize; 3];
        for axis in 0..3 {
            let negative = inv[axis].simd_lt(Lanes::ZERO).to_bitmask() & active;
            near[axis] = if negative == 0 {
                0
            } else if negative == active {
                1
            } else {
                return None;
            };
        }
        let (o, d) = rays.lanes(start);
        let slack = cull.slack();
        let org = Vec3x8::new(o[0], o[1], o[2]).to_array();
        let dir = Vec3x8::new(d[0], d[1], d[2]).to_array();
        Some(Packet {
            o,
            inv,
            near,
            slack,
            org,
            dir,
            lead: dir[active.trailing_zeros() as usize],
            tri: cull.packet_tri(active, &o, &org),
        })
    }

    /// Cull distance per lane for the current far ends `t_far`.
    #[inline(always)]
    fn cull(&self, t_far: Lanes) -> Lanes {
        t_far * Lanes::splat(T_FAR_MARGIN) + self.slack
    }

    /// Tests child `slot` of `node` against every lane; returns the lanes
    /// (within `mask`) that enter it and their entry distances.
    #[inline(always)]
    fn test(&self, node: &WideNode, slot: usize, cull: Lanes, mask: u32) -> (u32, Lanes) {
        let b = &node.bounds;
        let n = self.near;
        let plane = |corner: usize, axis: usize| Lanes::splat(b[corner][axis].as_array()[slot]);
        let (m, t_enter) = slab_test(
            [0, 1, 2].map(|a| plane(n[a], a)),
            [0, 1, 2].map(|a| plane(1 - n[a], a)),
            &self.o,
            &self.inv,
            cull,
        );
        (m.to_bitmask() & mask, t_enter)
    }
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
fn descend(
    packet: &Packet,
    node: &WideNode,
    mask: u32,
    cull: Lanes,
    stack: &mut PacketStack,
) -> Option<(ChildRef, u32)> {
    let mut slots = occupied(node);
    // Order key: the box centre (doubled) along the leading direction.
    let l = packet.lead;
    let key = (node.bounds[0][0] + node.bounds[1][0]) * Lanes::splat(l.x)
        + (node.bounds[0][1] + node.bounds[1][1]) * Lanes::splat(l.y)
        + (node.bounds[0][2] + node.bounds[1][2]) * Lanes::splat(l.z);
    let key = key.as_array();
    let mut masks = [0u32; WIDTH];
    let mut t_enter = [Lanes::ZERO; WIDTH];
    // Slots entered, insertion-sorted far to near.
    let mut order = [0usize; WIDTH];
    let mut n = 0;
    while slots != 0 {
        let slot = slots.trailing_zeros() as usize;
        slots &= slots - 1;
        let (m, t) = packet.test(node, slot, cull, mask);
        if m == 0 {
            continue;
        }
        masks[slot] = m;
        t_enter[slot] = t;
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
/// primitives each ray tested, `visits` the node visits summed over rays.
pub(crate) fn closest(
    scene: &Scene,
    stack: &mut PacketStack,
    packet: &Packet,
    active: u32,
    best: &mut [Closest; WIDTH],
    work: &mut [Work; WIDTH],
    visits: &mut u64,
) {
    let mut t_best = Lanes::from(best.map(|b| b.t));
    stack.clear();
    let mut current = (scene.root, active);
    loop {
        let (child, mask) = current;
        if !child.is_leaf() {
            let node = &scene.nodes[child.index()];
            *visits += u64::from(mask.count_ones());
            if let Some(next) = descend(packet, node, mask, packet.cull(t_best), stack) {
                current = next;
                continue;
            }
        } else {
            if child.is_sphere() {
                for i in crate::lanes::each(mask) {
                    let ray = (packet.org[i], packet.dir[i]);
                    let tri = packet.tri.ray(i);
                    scene.leaf_closest(child, ray, &tri, &mut best[i], &mut work[i]);
                }
            } else {
                scene.leaf_closest_packet(child, mask, &packet.tri, best, work);
            }
            t_best = Lanes::from(best.map(|b| b.t));
        }
        // Pop the next entry some ray still needs: entered no farther than
        // that ray's nearest hit so far.
        loop {
            let Some(e) = stack.pop() else {
                return;
            };
            let m = e.mask & e.t_enter.simd_le(packet.cull(t_best)).to_bitmask();
            if m != 0 {
                current = (ChildRef(e.child), m);
                break;
            }
        }
    }
}
