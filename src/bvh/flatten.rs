//! Collapsing the binary build tree into [`WIDTH`]-wide nodes.
//!
//! A binary BVH spends most of its traversal time on dependent loads: one
//! node, one box test, one branch. A wide node holds the boxes of up to
//! [`WIDTH`] children as one SIMD register per slab plane, so a single node
//! visit tests all of them at once and the tree is about three times
//! shallower (Wald et al., "Getting Rid of Packets", 2008; Dammertz et al.,
//! "Shallow Bounding Volume Hierarchies", 2008).
//!
//! Collapsing is greedy: starting from a node's two children, the interior
//! child with the largest surface area (the one most likely to be entered)
//! is replaced by its own two children until the node is full.
//!
//! Children are referred to by 32-bit [`ChildRef`]s that encode either a
//! node index or a leaf (kind, first item, item count), so a node is exactly
//! 6 bound registers plus [`WIDTH`] `u32`s, and leaves need no table of
//! their own. Leaf triangles are copied, in tree order, into contiguous
//! [`TriGroup`]s so that a leaf is one or two straight SIMD tests.
//!
//! Nodes are laid out depth first (a node's subtree follows it), which keeps
//! a traversal's path through nearby memory. Large subtrees are flattened on
//! other threads into arrays of their own and then appended with their
//! references shifted; an unused slot is recognised there by its inverted
//! box, since [`ChildRef::EMPTY`] shares its bits with a one-group leaf at
//! index 0 (harmless in traversal, where such a slot is never entered).

use glam::Vec3;

use super::build::BuildNode;
use super::sphere::PackedSphere;
use super::triangle::TriGroup;
use super::{Lanes, TRI_WIDTH, WIDTH};
use crate::scene::{Aabb, Geometry};

/// One wide node: the bounds of up to [`WIDTH`] children, lane-wise.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct WideNode {
    /// `bounds[axis][0]` = minimum plane, `bounds[axis][1]` = maximum
    /// plane, one register each. Axis-major, so that a ray's near and far
    /// planes along an axis are 32 bytes apart (the single-ray test's
    /// plane addresses take one shift each; PERF.md). Empty slots hold an
    /// inverted (+∞, −∞) box, which the slab test never hits, so
    /// traversal needs no occupancy mask.
    pub bounds: [[Lanes; 2]; 3],
    pub child: [ChildRef; WIDTH],
}

/// A child reference packed into 32 bits.
///
/// * bit 31 clear: interior node index.
/// * bit 31 set: leaf; bit 30 = sphere leaf; bits 27..30 = item count − 1;
///   bits 0..27 = index of the first item (a [`TriGroup`] for triangle
///   leaves, a [`PackedSphere`] for sphere leaves).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(transparent)]
pub(crate) struct ChildRef(pub u32);

impl ChildRef {
    const LEAF: u32 = 1 << 31;
    const SPHERE: u32 = 1 << 30;
    const COUNT_SHIFT: u32 = 27;
    /// Maximum items (groups or spheres) in one leaf.
    pub const MAX_ITEMS: u32 = 8;
    const INDEX_MASK: u32 = (1 << Self::COUNT_SHIFT) - 1;
    /// Placeholder for unused slots (never traversed: their box is empty).
    pub const EMPTY: ChildRef = ChildRef(Self::LEAF);

    pub fn node(index: u32) -> ChildRef {
        assert!(index < Self::LEAF, "too many BVH nodes");
        ChildRef(index)
    }

    pub fn leaf(sphere: bool, first: u32, count: u32) -> ChildRef {
        assert!(
            first <= Self::INDEX_MASK,
            "too many leaf items for 27-bit indices"
        );
        debug_assert!((1..=Self::MAX_ITEMS).contains(&count));
        ChildRef(
            Self::LEAF
                | if sphere { Self::SPHERE } else { 0 }
                | ((count - 1) << Self::COUNT_SHIFT)
                | first,
        )
    }

    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.0 & Self::LEAF != 0
    }

    #[inline(always)]
    pub fn is_sphere(self) -> bool {
        self.0 & Self::SPHERE != 0
    }

    #[inline(always)]
    pub fn index(self) -> usize {
        (self.0 & Self::INDEX_MASK) as usize
    }

    #[inline(always)]
    pub fn count(self) -> usize {
        (((self.0 >> Self::COUNT_SHIFT) & 7) + 1) as usize
    }
}

/// The flattened hierarchy and its leaf data.
pub(crate) struct Flat {
    pub nodes: Vec<WideNode>,
    pub tri_groups: Vec<TriGroup>,
    pub spheres: Vec<PackedSphere>,
    /// Reference to the root (always node 0 when there is a tree).
    pub root: Option<ChildRef>,
    /// Wide levels on the longest root-to-leaf path.
    pub depth: usize,
}

/// Flattens the binary tree `root` whose leaves index `order`.
pub(crate) fn flatten(root: Option<&BuildNode>, order: &[u32], geometry: &Geometry) -> Flat {
    let mut flat = Flat {
        nodes: Vec::new(),
        tri_groups: Vec::new(),
        spheres: Vec::new(),
        root: None,
        depth: 0,
    };
    let Some(root) = root else {
        return flat;
    };
    let mut ctx = Ctx {
        flat: &mut flat,
        order,
        geometry,
    };
    // The root is always an interior wide node, even for a single leaf, so
    // traversal can start with a box test unconditionally.
    let (slots, n) = match root {
        BuildNode::Inner { .. } => collapse_children(root),
        BuildNode::Leaf { .. } => ([root; WIDTH], 1),
    };
    let depth = ctx.emit_node(&slots[..n]);
    flat.root = Some(ChildRef::node(0));
    flat.depth = depth;
    flat
}

/// Interior children with more primitives than this are flattened in parallel.
const PARALLEL_FLATTEN: u32 = 1 << 13;

struct Ctx<'a> {
    flat: &'a mut Flat,
    order: &'a [u32],
    geometry: &'a Geometry,
}

/// Gathers up to [`WIDTH`] descendants of interior node `node` by repeatedly
/// opening the interior child with the largest surface area: the first
/// `n` entries of the returned array (no allocation: this runs once per
/// wide node).
fn collapse_children(node: &BuildNode) -> ([&BuildNode; WIDTH], usize) {
    let BuildNode::Inner { children, .. } = node else {
        unreachable!("collapse_children on a leaf")
    };
    let mut slots = [&children[0]; WIDTH];
    slots[1] = &children[1];
    let mut n = 2;
    // Joins of the build's isolated parts first (each part gets a slot),
    // then by area.
    let key = |n: &BuildNode| match n {
        BuildNode::Inner { joins_parts, .. } => Some((*joins_parts, n.bounds().surface_area())),
        BuildNode::Leaf { .. } => None,
    };
    while n < WIDTH {
        let best = slots[..n]
            .iter()
            .enumerate()
            .filter_map(|(i, n)| key(n).map(|k| (i, k)))
            .max_by(|a, b| a.1.0.cmp(&b.1.0).then(a.1.1.total_cmp(&b.1.1)));
        let Some((i, _)) = best else { break };
        let BuildNode::Inner { children, .. } = slots[i] else {
            unreachable!()
        };
        // Remove slot `i` (the last takes its place), append its children.
        slots[i] = slots[n - 1];
        slots[n - 1] = &children[0];
        slots[n] = &children[1];
        n += 1;
    }
    (slots, n)
}

impl Ctx<'_> {
    /// Appends a wide node with children `slots`; returns the depth of the
    /// subtree below it (in wide levels, counting itself).
    fn emit_node(&mut self, slots: &[&BuildNode]) -> usize {
        let index = self.flat.nodes.len();
        self.flat.nodes.push(WideNode {
            bounds: [[Lanes::splat(f32::INFINITY), Lanes::splat(f32::NEG_INFINITY)]; 3],
            child: [ChildRef::EMPTY; WIDTH],
        });
        let mut lo = [[f32::INFINITY; WIDTH]; 3];
        let mut hi = [[f32::NEG_INFINITY; WIDTH]; 3];
        let mut child = [ChildRef::EMPTY; WIDTH];
        let mut depth = 1;
        // Large interior children are flattened on other threads into
        // arrays of their own, appended (with their references shifted)
        // when their slot comes.
        let mut parallel: [Option<Flat>; WIDTH] = Default::default();
        let is_big =
            |n: &BuildNode| matches!(n, BuildNode::Inner { .. }) && n.count() > PARALLEL_FLATTEN;
        if slots.iter().filter(|n| is_big(n)).count() > 1 {
            use rayon::prelude::*;
            let big: Vec<(usize, &BuildNode)> = slots
                .iter()
                .enumerate()
                .filter(|(_, n)| is_big(n))
                .map(|(i, n)| (i, *n))
                .collect();
            let done: Vec<(usize, Flat)> = big
                .into_par_iter()
                .map(|(i, n)| (i, flatten(Some(n), self.order, self.geometry)))
                .collect();
            for (i, f) in done {
                parallel[i] = Some(f);
            }
        }
        for (slot, node) in slots.iter().enumerate() {
            let b = node.bounds();
            for axis in 0..3 {
                lo[axis][slot] = b.min[axis];
                hi[axis][slot] = b.max[axis];
            }
            child[slot] = match node {
                BuildNode::Leaf { start, count, .. } => {
                    self.emit_leaf(&self.order[*start as usize..(*start + *count) as usize])
                }
                BuildNode::Inner { .. } if parallel[slot].is_some() => {
                    let sub = parallel[slot].take().unwrap();
                    depth = depth.max(1 + sub.depth);
                    self.append(sub)
                }
                BuildNode::Inner { .. } => {
                    let c = ChildRef::node(self.flat.nodes.len() as u32);
                    let (slots, n) = collapse_children(node);
                    depth = depth.max(1 + self.emit_node(&slots[..n]));
                    c
                }
            };
        }
        let n = &mut self.flat.nodes[index];
        n.bounds = [0, 1, 2].map(|a| [Lanes::from(lo[a]), Lanes::from(hi[a])]);
        n.child = child;
        depth
    }

    /// Appends a separately flattened subtree, shifting its node and leaf
    /// references; returns the reference to its root.
    fn append(&mut self, sub: Flat) -> ChildRef {
        let node_base = self.flat.nodes.len() as u32;
        let group_base = self.flat.tri_groups.len() as u32;
        let sphere_base = self.flat.spheres.len() as u32;
        self.flat.nodes.extend(sub.nodes.into_iter().map(|mut n| {
            let [lo_x, hi_x] = n.bounds[0].map(Lanes::to_array);
            for (slot, c) in n.child.iter_mut().enumerate() {
                if lo_x[slot] > hi_x[slot] {
                    continue; // empty slot
                }
                *c = if !c.is_leaf() {
                    ChildRef::node(c.index() as u32 + node_base)
                } else if c.is_sphere() {
                    ChildRef::leaf(true, c.index() as u32 + sphere_base, c.count() as u32)
                } else {
                    ChildRef::leaf(false, c.index() as u32 + group_base, c.count() as u32)
                };
            }
            n
        }));
        self.flat.tri_groups.extend(sub.tri_groups);
        self.flat.spheres.extend(sub.spheres);
        ChildRef::node(node_base)
    }

    /// Copies a leaf's primitives (all of one kind) into the leaf arrays.
    fn emit_leaf(&mut self, prims: &[u32]) -> ChildRef {
        let tri_count = self.geometry.triangles.len() as u32;
        if prims[0] >= tri_count {
            let first = self.flat.spheres.len() as u32;
            for &id in prims {
                let s = (id - tri_count) as usize;
                self.flat.spheres.push(PackedSphere {
                    center: self.geometry.spheres.center[s],
                    radius: self.geometry.spheres.radius[s],
                    id,
                });
            }
            ChildRef::leaf(true, first, prims.len() as u32)
        } else {
            let first = self.flat.tri_groups.len() as u32;
            let tris = &self.geometry.triangles;
            self.flat
                .tri_groups
                .extend(prims.chunks(TRI_WIDTH).map(|ids| TriGroup::new(ids, tris)));
            let count = self.flat.tri_groups.len() as u32 - first;
            ChildRef::leaf(false, first, count)
        }
    }
}

/// Packs triangles `prims` into groups of [`TRI_WIDTH`].
pub(crate) fn pack_triangles(prims: &[u32], geometry: &Geometry) -> Vec<TriGroup> {
    prims
        .chunks(TRI_WIDTH)
        .map(|ids| TriGroup::new(ids, &geometry.triangles))
        .collect()
}

/// Bounds of a wide node's slot, for tests and statistics.
#[allow(dead_code)]
pub(crate) fn slot_bounds(node: &WideNode, slot: usize) -> Aabb {
    let corner = |side: usize| Vec3::from(node.bounds.map(|b| b[side].as_array()[slot]));
    Aabb {
        min: corner(0),
        max: corner(1),
    }
}
