//! Laying the binary build tree out as [`WIDTH`]-wide nodes.
//!
//! A binary BVH spends most of its traversal time on dependent loads: one
//! node, one box test, one branch. A wide node holds the boxes of up to
//! [`WIDTH`] children as one SIMD register per slab plane, so a single node
//! visit tests all of them at once and the tree is about three times
//! shallower (Wald et al., "Getting Rid of Packets", 2008; Dammertz et al.,
//! "Shallow Bounding Volume Hierarchies", 2008).
//!
//! Which binary nodes become a wide node's slots is decided by
//! [`collapse`](super::collapse) (least SAH cost, by dynamic programming),
//! except at the joins of the parts the build set apart (the large flat
//! pieces of a scene): those are opened first, greedily, so each part gets
//! a slot of the root.
//!
//! Children are referred to by 32-bit [`ChildRef`]s that encode either a
//! node index or a leaf (kind, first item, item count), so a node is exactly
//! 6 bound registers plus [`WIDTH`] `u32`s, and leaves need no table of
//! their own. Leaf triangles are copied, in tree order, into contiguous
//! [`TriGroup`]s so that a leaf is one or two straight SIMD tests.
//!
//! Nodes are laid out depth first (a node's subtree follows it), which keeps
//! a traversal's path through nearby memory. The arrays are sized first and
//! then written in place, large subtrees on other threads, each into the
//! slice that its size cuts off (see [`flatten`]). An unused slot holds
//! [`ChildRef::EMPTY`], which shares its bits with a one-group leaf at
//! index 0; that is harmless, since its inverted box is never entered.

use super::build::BuildNode;
use super::collapse::Plan;
use super::sphere::PackedSphere;
use super::triangle::TriGroup;
use super::{Lanes, TRI_WIDTH, WIDTH};
use crate::scene::Geometry;
use std::collections::HashMap;
use std::ops::Add;
use std::sync::Mutex;

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
///
/// Two passes over the collapse plan, then one over the triangle groups.
/// The first counts what each subtree lays out ([`Extent`]), so the arrays
/// are allocated once at their final size; the second writes every node
/// and sphere in place and, for each triangle group, which primitives go
/// in it. Large subtrees are laid out on other threads, each into its own
/// slice of the arrays, cut off by its extent. Last, the groups (320 bytes
/// each, nearly all of a tree's memory) are packed in parallel straight
/// into their array. Nothing is copied or regrown after it is written:
/// appending subtrees laid out apart had copied the groups once per level
/// of parallel nesting, 190 MB several times over for 4M triangles, with
/// page faults on every regrowth (PERF.md).
pub(crate) fn flatten(root: Option<&BuildNode>, order: &[u32], geometry: &Geometry) -> Flat {
    let Some(root) = root else {
        return Flat {
            nodes: Vec::new(),
            tri_groups: Vec::new(),
            spheres: Vec::new(),
            root: None,
            depth: 0,
        };
    };
    let plan = Plan::new(root, geometry.triangles.len() as u32, order);
    let layout = Layout {
        order,
        geometry,
        parts: Mutex::new(HashMap::new()),
    };
    // The root is always an interior wide node, even for a single leaf, so
    // traversal can start with a box test unconditionally.
    let (slots, n) = match plan.children() {
        Some(_) => wide_slots(&plan),
        None => ([&plan; WIDTH], 1),
    };
    let slots = &slots[..n];
    let total = layout.node_extent(slots);

    let mut nodes = vec![EMPTY_NODE; total.nodes];
    let mut groups = vec![GroupPrims::default(); total.groups];
    let placeholder = PackedSphere {
        center: glam::Vec3::ZERO,
        radius: 0.0,
        id: 0,
    };
    let mut spheres = vec![placeholder; total.spheres];
    let mut region = Region {
        nodes: &mut nodes,
        groups: &mut groups,
        spheres: &mut spheres,
        base: Extent::default(),
    };
    let depth = layout.emit_node(slots, &mut region);
    assert!(region.is_empty(), "the extent pass and the layout disagree");
    let tri_groups = {
        use rayon::prelude::*;
        let tris = &geometry.triangles;
        groups
            .par_iter()
            .map(|g| TriGroup::new(&order[g.start as usize..g.end as usize], tris))
            .collect()
    };
    Flat {
        nodes,
        tri_groups,
        spheres,
        root: Some(ChildRef::node(0)),
        depth,
    }
}

/// Interior children with more primitives than this are counted and laid
/// out in parallel (when a node has two or more of them).
const PARALLEL_FLATTEN: u32 = 1 << 13;

/// Whether slot `plan` is an interior subtree large enough for a thread.
fn big(plan: &Plan) -> bool {
    !plan.as_leaf() && plan.node.count() > PARALLEL_FLATTEN
}

/// Whether a wide node's big slots (two or more) go to other threads.
fn parallel(slots: &[&Plan]) -> bool {
    slots.iter().filter(|p| big(p)).count() > 1
}

/// Key of a subtree of the plan, which stays in place while it is laid out.
fn plan_key(plan: &Plan) -> usize {
    plan as *const Plan as usize
}

/// The primitives of one triangle group: `order[start..end]`.
#[derive(Clone, Copy, Debug, Default)]
struct GroupPrims {
    start: u32,
    end: u32,
}

/// A wide node with every slot empty.
const EMPTY_NODE: WideNode = WideNode {
    bounds: [[Lanes::splat(f32::INFINITY), Lanes::splat(f32::NEG_INFINITY)]; 3],
    child: [ChildRef::EMPTY; WIDTH],
};

/// How many wide nodes, triangle groups and spheres a subtree lays out —
/// or, as a [`Region`]'s base, the index in the whole arrays of its first
/// of each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Extent {
    nodes: usize,
    groups: usize,
    spheres: usize,
}

impl Add for Extent {
    type Output = Extent;
    fn add(self, o: Extent) -> Extent {
        Extent {
            nodes: self.nodes + o.nodes,
            groups: self.groups + o.groups,
            spheres: self.spheres + o.spheres,
        }
    }
}

/// The part of the output arrays that a subtree is laid out in; it is
/// filled from the front, and `base` says where its front lies in the whole
/// arrays (child references are global indices).
struct Region<'o> {
    nodes: &'o mut [WideNode],
    groups: &'o mut [GroupPrims],
    spheres: &'o mut [PackedSphere],
    base: Extent,
}

impl<'o> Region<'o> {
    /// Takes the first `e` of each array off the front, as a region of
    /// its own.
    fn take_front(&mut self, e: Extent) -> Region<'o> {
        fn split<'s, T>(v: &mut &'s mut [T], n: usize) -> &'s mut [T] {
            let (head, tail) = std::mem::take(v).split_at_mut(n);
            *v = tail;
            head
        }
        let base = self.base;
        self.base = base + e;
        Region {
            nodes: split(&mut self.nodes, e.nodes),
            groups: split(&mut self.groups, e.groups),
            spheres: split(&mut self.spheres, e.spheres),
            base,
        }
    }

    fn is_empty(&self) -> bool {
        self.nodes.is_empty() && self.groups.is_empty() && self.spheres.is_empty()
    }
}

/// What the layout reads besides the plan.
struct Layout<'a> {
    order: &'a [u32],
    geometry: &'a Geometry,
    /// The extents of the subtrees laid out in parallel, by [`plan_key`],
    /// as the counting pass found them (so that no subtree is counted twice).
    parts: Mutex<HashMap<usize, Extent>>,
}

/// The extent of one wide node alone.
const ONE_NODE: Extent = Extent {
    nodes: 1,
    groups: 0,
    spheres: 0,
};

impl Layout<'_> {
    /// The primitives of leaf slot `plan`, whether they are spheres (a
    /// leaf never mixes kinds), and what the leaf lays out.
    fn leaf(&self, plan: &Plan) -> (&[u32], bool, Extent) {
        let start = plan.start as usize;
        let prims = &self.order[start..start + plan.node.count() as usize];
        let spheres = prims[0] >= self.geometry.triangles.len() as u32;
        let extent = if spheres {
            Extent {
                spheres: prims.len(),
                ..Extent::default()
            }
        } else {
            Extent {
                groups: prims.len().div_ceil(TRI_WIDTH),
                ..Extent::default()
            }
        };
        (prims, spheres, extent)
    }

    /// What interior slot `plan` lays out: its wide node and everything
    /// below.
    fn subtree_extent(&self, plan: &Plan) -> Extent {
        let (slots, n) = wide_slots(plan);
        self.node_extent(&slots[..n])
    }

    /// What the wide node of `slots`, and everything below it, lays out;
    /// records the extents of the subtrees to be laid out in parallel.
    fn node_extent(&self, slots: &[&Plan]) -> Extent {
        let slot = |plan: &&Plan| match plan.as_leaf() {
            true => self.leaf(plan).2,
            false => self.subtree_extent(plan),
        };
        if !parallel(slots) {
            return slots.iter().map(slot).fold(ONE_NODE, Extent::add);
        }
        use rayon::prelude::*;
        let extents: Vec<Extent> = slots.par_iter().map(slot).collect();
        let mut parts = self.parts.lock().expect("a counting thread panicked");
        for (plan, &e) in slots.iter().zip(&extents) {
            if big(plan) {
                parts.insert(plan_key(plan), e);
            }
        }
        extents.into_iter().fold(ONE_NODE, Extent::add)
    }

    /// The extent [`node_extent`](Self::node_extent) recorded for `plan`, a
    /// subtree laid out in parallel.
    fn counted(&self, plan: &Plan) -> Extent {
        let parts = self.parts.lock().expect("a counting thread panicked");
        *parts
            .get(&plan_key(plan))
            .expect("parallel subtrees are counted")
    }

    /// Writes interior slot `plan` (its wide node and subtree) at the front
    /// of `region`, as [`emit_node`](Self::emit_node) does; returns its depth.
    fn emit_subtree(&self, plan: &Plan, region: &mut Region) -> usize {
        let (slots, n) = wide_slots(plan);
        self.emit_node(&slots[..n], region)
    }

    /// Writes the wide node of `slots` and its subtree at the front of
    /// `region` (depth first: the node, then each slot's subtree in slot
    /// order), taking what it fills off the region; returns the subtree's
    /// depth in wide levels, counting the node itself.
    fn emit_node(&self, slots: &[&Plan], region: &mut Region) -> usize {
        let this = region.take_front(ONE_NODE);
        let mut lo = [[f32::INFINITY; WIDTH]; 3];
        let mut hi = [[f32::NEG_INFINITY; WIDTH]; 3];
        let mut child = [ChildRef::EMPTY; WIDTH];
        let mut depth = 1;
        // Large interior children get their regions cut off here and are
        // laid out together once every slot's place is known.
        let in_parallel = parallel(slots);
        let mut apart = Vec::new();
        for (slot, plan) in slots.iter().enumerate() {
            let b = plan.node.bounds();
            for axis in 0..3 {
                lo[axis][slot] = b.min[axis];
                hi[axis][slot] = b.max[axis];
            }
            child[slot] = if plan.as_leaf() {
                self.emit_leaf(plan, region)
            } else {
                let c = ChildRef::node(region.base.nodes as u32);
                if in_parallel && big(plan) {
                    apart.push((*plan, region.take_front(self.counted(plan))));
                } else {
                    depth = depth.max(1 + self.emit_subtree(plan, region));
                }
                c
            };
        }
        if !apart.is_empty() {
            use rayon::prelude::*;
            let deepest = apart
                .into_par_iter()
                .map(|(plan, mut own)| {
                    let d = self.emit_subtree(plan, &mut own);
                    assert!(own.is_empty(), "a subtree's extent and layout disagree");
                    d
                })
                .max()
                .unwrap_or(0);
            depth = depth.max(1 + deepest);
        }
        this.nodes[0] = WideNode {
            bounds: [0, 1, 2].map(|a| [Lanes::from(lo[a]), Lanes::from(hi[a])]),
            child,
        };
        depth
    }

    /// Writes a leaf slot's spheres, or which primitives its triangle
    /// groups take, at the front of `region`, taking them off it; returns
    /// the leaf's reference.
    fn emit_leaf(&self, plan: &Plan, region: &mut Region) -> ChildRef {
        let (prims, spheres, extent) = self.leaf(plan);
        let base = region.base;
        let out = region.take_front(extent);
        if spheres {
            let tri_count = self.geometry.triangles.len() as u32;
            let s = &self.geometry.spheres;
            for (o, &id) in out.spheres.iter_mut().zip(prims) {
                let i = (id - tri_count) as usize;
                *o = PackedSphere {
                    center: s.center[i],
                    radius: s.radius[i],
                    id,
                };
            }
            ChildRef::leaf(true, base.spheres as u32, prims.len() as u32)
        } else {
            let (start, end) = (plan.start, plan.start + prims.len() as u32);
            for (k, o) in out.groups.iter_mut().enumerate() {
                let group_start = start + (k * TRI_WIDTH) as u32;
                *o = GroupPrims {
                    start: group_start,
                    end: end.min(group_start + TRI_WIDTH as u32),
                };
            }
            ChildRef::leaf(false, base.groups as u32, extent.groups as u32)
        }
    }
}

/// The slots of the wide node made of interior subtree `plan`: the first
/// `n` entries of the returned array (no allocation: this runs once per
/// wide node).
fn wide_slots<'p, 'a>(plan: &'p Plan<'a>) -> ([&'p Plan<'a>; WIDTH], usize) {
    let joins_parts = |p: &Plan| {
        matches!(
            p.node,
            BuildNode::Inner {
                joins_parts: true,
                ..
            }
        )
    };
    if !joins_parts(plan) {
        return plan.slots();
    }
    // Open the joins first, then the interior child with the largest
    // surface area, until the node is full (the layout before the
    // least-cost collapse: a part may be opened even where the plan would
    // keep it whole, since the cost model does not see what its own root
    // slot is for; PERF.md, fifth and twelfth sessions).
    let [left, right] = plan.children().expect("joins are interior");
    let mut slots = [left; WIDTH];
    slots[1] = right;
    let mut n = 2;
    let key = |p: &Plan| {
        p.children()
            .map(|_| (joins_parts(p), p.node.bounds().surface_area()))
    };
    while n < WIDTH {
        let best = slots[..n]
            .iter()
            .enumerate()
            .filter_map(|(i, p)| key(p).map(|k| (i, k)))
            .max_by(|a, b| a.1.0.cmp(&b.1.0).then(a.1.1.total_cmp(&b.1.1)));
        let Some((i, _)) = best else { break };
        let [left, right] = slots[i].children().expect("keyed slots are interior");
        // Remove slot `i` (the last takes its place), append its children.
        slots[i] = slots[n - 1];
        slots[n - 1] = left;
        slots[n] = right;
        n += 1;
    }
    (slots, n)
}

/// Packs triangles `prims` into groups of [`TRI_WIDTH`].
pub(crate) fn pack_triangles(prims: &[u32], geometry: &Geometry) -> Vec<TriGroup> {
    prims
        .chunks(TRI_WIDTH)
        .map(|ids| TriGroup::new(ids, &geometry.triangles))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build::{self, BuildParams};
    use crate::bvh::collapse::{C_NODE, C_PRIM};
    use crate::sampling::rng::{hash32, to_unit_float};
    use crate::scene::{Aabb, Spheres, Triangles};
    use glam::Vec3;

    /// Bounds of a wide node's slot.
    fn slot_bounds(node: &WideNode, slot: usize) -> Aabb {
        let corner = |side: usize| Vec3::from(node.bounds.map(|b| b[side].as_array()[slot]));
        Aabb {
            min: corner(0),
            max: corner(1),
        }
    }

    /// Random geometry: `triangles` small triangles (lying in one of four
    /// planes x = const when `flat_x`, so that many slot boxes have zero
    /// width in x) and `spheres` small spheres, in a cube of side 20.
    fn random_geometry(seed: u32, triangles: usize, spheres: usize, flat_x: bool) -> Geometry {
        let mut draw = 0;
        let mut next = move || {
            draw += 1;
            to_unit_float(hash32(seed.wrapping_mul(0x9e37_79b9) ^ draw))
        };
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for t in 0..triangles as u32 {
            let c = Vec3::new(next(), next(), next()) * 20.0;
            let plane = (next() * 4.0).floor() * 5.0;
            for _ in 0..3 {
                let p = c + Vec3::new(next(), next(), next()) * 0.5;
                positions.push(if flat_x {
                    Vec3::new(plane, p.y, p.z)
                } else {
                    p
                });
            }
            indices.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        let center: Vec<Vec3> = (0..spheres)
            .map(|_| Vec3::new(next(), next(), next()) * 20.0)
            .collect();
        Geometry {
            triangles: Triangles {
                positions,
                normals: Vec::new(),
                material: vec![0; triangles],
                indices,
                texcoords: Vec::new(),
            },
            spheres: Spheres {
                radius: (0..spheres).map(|_| 0.05 + next() * 0.3).collect(),
                center,
                material: vec![0; spheres],
            },
        }
    }

    /// What a walk of a flattened tree finds: how many times each
    /// primitive is laid out (a sphere's copy checked against its own
    /// centre and radius, inside its slot), the SAH cost summed over the
    /// wide nodes and leaves, and the longest path in wide levels.
    fn walk(flat: &Flat, geometry: &Geometry, root_area: f32) -> (Vec<u32>, f32, usize) {
        let triangles = geometry.triangles.len();
        let mut seen = vec![0; triangles + geometry.spheres.len()];
        let mut cost = C_NODE;
        let mut depth = 0;
        let mut stack = vec![(0usize, 1)];
        while let Some((index, level)) = stack.pop() {
            depth = depth.max(level);
            let node = &flat.nodes[index];
            for slot in 0..WIDTH {
                let b = slot_bounds(node, slot);
                if b.min.x > b.max.x {
                    continue; // empty slot
                }
                let area = b.surface_area() / root_area;
                let c = node.child[slot];
                if !c.is_leaf() {
                    cost += area * C_NODE;
                    stack.push((c.index(), level + 1));
                    continue;
                }
                cost += area * C_PRIM * c.count() as f32;
                let items = c.index()..c.index() + c.count();
                if c.is_sphere() {
                    for s in &flat.spheres[items] {
                        let i = s.id as usize - triangles;
                        assert_eq!(s.center, geometry.spheres.center[i]);
                        assert_eq!(s.radius, geometry.spheres.radius[i]);
                        let inside = b.min.cmple(s.center).all() && s.center.cmple(b.max).all();
                        assert!(inside, "sphere {i} outside its slot");
                        seen[s.id as usize] += 1;
                    }
                } else {
                    let groups = &flat.tri_groups[items];
                    for id in groups.iter().flat_map(TriGroup::prims) {
                        seen[id as usize] += 1;
                    }
                }
            }
        }
        (seen, cost, depth)
    }

    /// Builds `geometry` with the renderer's SAH parameters, and with
    /// `top_slots` root slots for large flat pieces.
    fn build_sah(geometry: &Geometry, top_slots: usize) -> (BuildNode, Vec<u32>) {
        let n = geometry.triangles.len() + geometry.spheres.len();
        let bounds: Vec<Aabb> = (0..n as u32)
            .map(|i| geometry.primitive_bounds(i))
            .collect();
        let params = BuildParams {
            sah: true,
            bins: 16,
            traversal_cost: 2.0,
            lanes: TRI_WIDTH,
            max_leaf: 8,
            top_slots,
        };
        let (root, order) = build::build(&bounds, geometry.triangles.len() as u32, params);
        (root.expect("primitives were given"), order)
    }

    /// The flattened tree is the plan: every primitive in exactly one leaf,
    /// its SAH cost (summed over the wide nodes and leaves actually laid
    /// out) the plan's least cost, and its depth the longest path laid out.
    #[test]
    fn layout_follows_the_plan() {
        // (triangles, spheres, triangles flat in x). 20,000 primitives
        // also take the parallel plan; 80,000 the parallel layout too
        // (several root slots above PARALLEL_FLATTEN), whose subtrees are
        // written into the slices their counted extents cut off.
        let cases = [
            (1, 0, false),
            (7, 0, false),
            (9, 0, false),
            (100, 0, false),
            (3000, 0, false),
            (20_000, 0, false),
            (80_000, 0, true),
            (0, 80_000, false),
            (3000, 3000, true),
        ];
        for (seed, (triangles, spheres, flat_x)) in cases.into_iter().enumerate() {
            let geometry = random_geometry(seed as u32, triangles, spheres, flat_x);
            let (root, order) = build_sah(&geometry, 0);
            let flat = flatten(Some(&root), &order, &geometry);
            let case = format!("{triangles} triangles, {spheres} spheres, flat {flat_x}");

            let (seen, cost, depth) = walk(&flat, &geometry, root.bounds().surface_area());
            assert!(seen.iter().all(|&s| s == 1), "{case}: {seen:?}");
            assert_eq!(flat.depth, depth, "{case}");
            let plan = Plan::new(&root, triangles as u32, &order);
            let want = match root {
                BuildNode::Inner { .. } => plan.wide_cost,
                // A lone leaf still gets a root node.
                BuildNode::Leaf { .. } => C_NODE + plan.cost_as_slot(),
            };
            assert!(
                (cost - want).abs() <= 1e-4 * want,
                "{case}: laid out {cost}, planned {want}"
            );
        }
    }

    /// Walls in root slots of their own (the root's joins are opened
    /// greedily, not as the plan would) around enough small triangles for
    /// the parallel layout: every primitive is laid out once, at the
    /// counted depth, and each wall is a slot of the root.
    #[test]
    fn layout_gives_the_walls_root_slots() {
        let mut geometry = random_geometry(11, 80_000, 0, false);
        let t = &mut geometry.triangles;
        // The six walls of a room around the cube of side 20 that the
        // small triangles fill, two triangles each.
        let (lo, hi) = (-10.0, 30.0);
        for axis in 0..3 {
            for side in [lo, hi] {
                let corner = |u: f32, v: f32| {
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = u;
                    p[(axis + 2) % 3] = v;
                    Vec3::from(p)
                };
                let base = t.positions.len() as u32;
                t.positions.extend([
                    corner(lo, lo),
                    corner(hi, lo),
                    corner(hi, hi),
                    corner(lo, hi),
                ]);
                t.indices.push([base, base + 1, base + 2]);
                t.indices.push([base, base + 2, base + 3]);
                t.material.extend([0, 0]);
            }
        }
        let (root, order) = build_sah(&geometry, WIDTH);
        assert!(
            matches!(
                root,
                BuildNode::Inner {
                    joins_parts: true,
                    ..
                }
            ),
            "the walls were not set apart"
        );
        let flat = flatten(Some(&root), &order, &geometry);
        let (seen, _, depth) = walk(&flat, &geometry, root.bounds().surface_area());
        assert!(seen.iter().all(|&s| s == 1), "{seen:?}");
        assert_eq!(flat.depth, depth);
        // Each wall's two triangles are one leaf slot of the root.
        let root_node = &flat.nodes[0];
        for wall in 0..6 {
            let ids = [80_000 + 2 * wall, 80_000 + 2 * wall + 1];
            let holds_wall = (0..WIDTH).any(|slot| {
                let c = root_node.child[slot];
                c.is_leaf() && !c.is_sphere() && c.count() == 1 && {
                    let mut got: Vec<u32> = flat.tri_groups[c.index()].prims().collect();
                    got.sort();
                    got == ids
                }
            });
            assert!(holds_wall, "wall {wall} has no root slot of its own");
        }
    }
}
