//! Bundle traversal for any-hit queries: up to [`WIDTH`] rays walk the
//! tree together, each one tested on its own at every node it reaches.
//!
//! Single-ray traversal tests one ray against a node's [`WIDTH`] child
//! boxes at once; most of its cost per node is not that test but the
//! control around it: the branch on which children were hit, the stack,
//! the loop — branches that mispredict because every ray takes its own
//! path. A bundle keeps the single-ray box test (lanes = children, each ray
//! with its own near planes, reciprocals and `t_max`) and shares the
//! control: at a node, every ray of the bundle that entered it is tested,
//! the results are merged child by child into the mask of rays entering it
//! (a bit per ray), and the children entered by any ray are visited once
//! for all.
//!
//! A ray is tested only at the nodes whose box it entered, and leaves the
//! bundle at its first occluder. The walk's order is the bundle's (slot
//! order over the children any ray entered), not quite the ray's own, so a
//! ray may meet its first occluder a little sooner or later than alone;
//! the answer — occluded or not — is the same. Nothing need be common to
//! the rays: no octant, origin or light. What a bundle saves grows with
//! how many nodes its rays share: the `-l` shadow rays of one path vertex
//! share most of the top of the tree, as do neighbouring vertices' rays
//! toward one light.
//!
//! The same layout for closest-hit rays (children ordered by the nearest
//! entry among the rays, entries dropped for a ray beyond its hit) was
//! measured and not kept: 5–10% slower CBbunny renders, as a child entered
//! by several rays is ordered by the nearest of them, so a ray may test a
//! far leaf before the near node whose hit would have culled it (PERF.md).

use glam::Vec3;

use super::flatten::{ChildRef, WideNode};
use super::traverse::{Cull, Ray8Src, RayBox, Scene, Work};
use super::triangle::RayTri;
use super::{Lanes, WIDTH};
use crate::lanes::{Vec3x8, each, from_bits, to_bits};

/// Stack entry: a child and the rays that entered it (a bit per lane).
#[derive(Clone, Copy)]
pub(crate) struct BundleEntry {
    child: u32,
    rays: u32,
}

/// Traversal stack of a bundle (reused across the bundles of a batch). It
/// grows as needed, so creating one initialises nothing.
pub(crate) type BundleStack = Vec<BundleEntry>;

pub(crate) fn new_bundle_stack() -> BundleStack {
    Vec::with_capacity(64)
}

/// The rays of one batch slot with their per-ray traversal constants.
pub(crate) struct Bundle<'c> {
    cull: &'c Cull,
    org: [Vec3; WIDTH],
    dir: [Vec3; WIDTH],
}

impl<'c> Bundle<'c> {
    /// The rays `start..start + WIDTH` of `rays` (those the batch `cull`
    /// let through are the ones traced).
    #[inline(always)]
    pub fn new(rays: &Ray8Src, start: usize, cull: &'c Cull) -> Bundle<'c> {
        let (o, d) = rays.lanes(start);
        Bundle {
            cull,
            org: Vec3x8::new(o[0], o[1], o[2]).to_array(),
            dir: Vec3x8::new(d[0], d[1], d[2]).to_array(),
        }
    }

    /// Triangle-test setup of the ray in `lane`, made at each leaf the ray
    /// reaches (a few operations) rather than for every ray up front: most
    /// shadow rays in a room never reach one.
    #[inline(always)]
    fn ray_tri(&self, lane: usize) -> RayTri {
        self.cull.ray_tri(lane, self.org[lane])
    }

    /// Slab-test constants of the ray in `lane`.
    #[inline(always)]
    fn ray_box(&self, lane: usize) -> RayBox {
        self.cull.ray_box(lane, self.org[lane])
    }

    /// Tests the children of `node` against the rays of `rays`, each up to
    /// its own `t_max[lane]`: returns the slots entered by any ray and, per
    /// slot, the rays that enter it (a bit per lane).
    #[inline(always)]
    fn test(&self, node: &WideNode, rays: u32, t_max: &[f32; WIDTH]) -> (u32, [u32; WIDTH]) {
        // Lane `slot` of `entered` collects bit `i` for each ray `i` that
        // enters child `slot`: the transpose of the rays' hit masks, built
        // with one vector AND and OR per ray.
        let mut entered = Lanes::ZERO;
        let mut slots = 0;
        for i in each(rays) {
            let (hit, _) = self.ray_box(i).test_lanes(node, t_max[i]);
            slots |= hit.to_bitmask();
            entered |= hit & from_bits(wide::i32x8::splat(1 << i));
        }
        let entered: [i32; WIDTH] = to_bits(entered).to_array();
        (slots, entered.map(|m| m as u32))
    }
}

/// Pushes the children of `node` in `slots` except the first, which it
/// returns: any-hit order, no sorting.
#[inline(always)]
fn push_entered(
    node: &WideNode,
    slots: u32,
    rays: &[u32; WIDTH],
    stack: &mut BundleStack,
) -> (ChildRef, u32) {
    let first = slots.trailing_zeros() as usize;
    for slot in each(slots & (slots - 1)) {
        stack.push(BundleEntry {
            child: node.child[slot].0,
            rays: rays[slot],
        });
    }
    (node.child[first], rays[first])
}

/// Any-hit test of the bundle's `active` rays (each up to its `t_max`);
/// returns the mask of occluded rays. `work` receives the primitives each
/// ray tested, `visits` the node visits summed over rays.
pub(crate) fn any<const WALK: u8>(
    scene: &Scene,
    stack: &mut BundleStack,
    bundle: &Bundle,
    active: u32,
    t_max: &[f32; WIDTH],
    work: &mut [Work; WIDTH],
    visits: &mut u64,
) -> u32 {
    // Only rays the batch cull let through may be traced (see `never_hits`).
    debug_assert!(active & !bundle.cull.mask == 0);
    // Rays still looking for an occluder.
    let mut open = active;
    stack.clear();
    let mut current = (scene.root, active);
    loop {
        let (child, rays) = current;
        if !child.is_leaf() {
            let node = &scene.nodes[child.index()];
            *visits += u64::from(rays.count_ones());
            let (slots, entered) = bundle.test(node, rays, t_max);
            if slots != 0 {
                current = push_entered(node, slots, &entered, stack);
                continue;
            }
        } else {
            for i in each(rays) {
                let ray = (bundle.org[i], bundle.dir[i], t_max[i]);
                if scene.leaf_occludes::<WALK>(child, ray, &bundle.ray_tri(i), &mut work[i]) {
                    open &= !(1 << i);
                }
            }
            if open == 0 {
                return active;
            }
        }
        loop {
            let Some(e) = stack.pop() else {
                return active & !open;
            };
            let rays = e.rays & open;
            if rays != 0 {
                current = (ChildRef(e.child), rays);
                break;
            }
        }
    }
}
