//! Which binary nodes become the slots of each wide node: the collapse of
//! the binary build tree with the least SAH cost, by dynamic programming
//! (Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs
//! Through Compressed Wide BVHs", HPG 2017, section 3.1).
//!
//! A greedy collapse (open the largest child until the node is full) fills
//! the top of the tree but leaves many small subtrees near the leaves
//! as wide nodes of two or three children, each costing a visit. The
//! program instead asks, for every binary node `n` and every `i` in
//! `1..=WIDTH`, what the cheapest way is to represent `n`'s subtree as at
//! most `i` slots of a wide node:
//!
//! ```text
//! cost(n, 1) = min( leaf(n),  A(n)·C_NODE + dist(n, WIDTH) )
//! cost(n, i) = min( cost(n, i − 1),  dist(n, i) )                   i ≥ 2
//! dist(n, j) = min over k in 1..j of  cost(left, k) + cost(right, j − k)
//! ```
//!
//! where `A` is the surface area relative to the root's, `leaf(n)` the cost
//! of testing all of `n`'s primitives as one leaf (a binary leaf always can
//! be; an interior node only when its triangles fit in one [`TRI_WIDTH`]
//! group), and `dist(n, j)` shares `j` slots between the two children. The
//! tree is `cost(root, …)` with the root forced to be a wide node.
//!
//! Costs are in units of one wide-node visit; a triangle group test or a
//! sphere test costs [`C_PRIM`] of them, the ratio of their shares of
//! traversal time per visit (PERF.md). The program is O(WIDTH²) per binary
//! node, well under a millisecond per 100k triangles, and runs on rayon for
//! large subtrees as the build does.

use super::build::BuildNode;
use super::{TRI_WIDTH, WIDTH};

/// Cost of a wide-node visit (the unit).
pub(crate) const C_NODE: f32 = 1.0;
/// Cost of one triangle-group or sphere test, in wide-node visits.
pub(crate) const C_PRIM: f32 = 1.4;

/// Subtrees above this many primitives plan their two children in parallel.
const PARALLEL_PLAN: u32 = 1 << 12;

/// Half the surface area of `node`'s box, in f64: finite for any finite
/// coordinates (in f32 it overflows beyond about 1e19).
fn half_area(node: &BuildNode) -> f64 {
    let b = node.bounds();
    let e = (b.max - b.min).as_dvec3();
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// The collapse plan of one binary subtree.
pub(crate) struct Plan<'a> {
    pub node: &'a BuildNode,
    /// First index into the leaf order covered by the subtree (a subtree's
    /// primitives are contiguous there).
    pub start: u32,
    /// All primitives below are triangles (a leaf never mixes kinds).
    triangles: bool,
    /// `cost[i − 1]` = cost(n, i).
    cost: [f32; WIDTH],
    /// Bit `i`: cost(n, i) is cost(n, i − 1) (fewer slots are as cheap).
    fewer: u32,
    /// `split[j]`: the left child's share of the `j` slots in dist(n, j).
    split: [u8; WIDTH + 1],
    /// The subtree as one wide node: A(n)·C_NODE + dist(n, WIDTH)
    /// (∞ for a binary leaf).
    pub wide_cost: f32,
    children: Option<Box<[Plan<'a>; 2]>>,
}

impl<'a> Plan<'a> {
    /// Plans the tree `root` whose leaves index `order`; primitive ids
    /// below `triangle_count` are triangles.
    pub fn new(root: &'a BuildNode, triangle_count: u32, order: &[u32]) -> Plan<'a> {
        let root_area = half_area(root).max(f64::MIN_POSITIVE);
        Self::subtree(root, 0, triangle_count, order, root_area)
    }

    fn subtree(
        node: &'a BuildNode,
        start: u32,
        triangle_count: u32,
        order: &[u32],
        root_area: f64,
    ) -> Plan<'a> {
        // Relative to the root's, so in [0, 1] and finite.
        let area = (half_area(node) / root_area) as f32;
        match node {
            BuildNode::Leaf {
                count,
                start: leaf_start,
                ..
            } => {
                debug_assert_eq!(*leaf_start, start, "subtrees cover contiguous ranges");
                let triangles = order[start as usize] < triangle_count;
                let tests = if triangles {
                    count.div_ceil(TRI_WIDTH as u32)
                } else {
                    *count
                };
                Plan {
                    node,
                    start,
                    triangles,
                    cost: [area * C_PRIM * tests as f32; WIDTH],
                    fewer: !0,
                    split: [0; WIDTH + 1],
                    wide_cost: f32::INFINITY,
                    children: None,
                }
            }
            BuildNode::Inner {
                children, count, ..
            } => {
                let right_start = start + children[0].count();
                let plan_child =
                    |child, at| Self::subtree(child, at, triangle_count, order, root_area);
                let (left, right) = if *count > PARALLEL_PLAN {
                    rayon::join(
                        || plan_child(&children[0], start),
                        || plan_child(&children[1], right_start),
                    )
                } else {
                    (
                        plan_child(&children[0], start),
                        plan_child(&children[1], right_start),
                    )
                };
                let triangles = left.triangles && right.triangles;
                // dist(n, j) for j = 2..=WIDTH, and the left share that
                // achieves it.
                let mut dist = [f32::INFINITY; WIDTH + 1];
                // Each child takes at least one slot (areas are finite, so
                // a comparison below always succeeds; 1 is a valid default).
                let mut split = [1u8; WIDTH + 1];
                for j in 2..=WIDTH {
                    for k in 1..j {
                        let c = left.cost[k - 1] + right.cost[j - k - 1];
                        if c < dist[j] {
                            dist[j] = c;
                            split[j] = k as u8;
                        }
                    }
                }
                let wide = area * C_NODE + dist[WIDTH];
                let leaf = if triangles && *count as usize <= TRI_WIDTH {
                    area * C_PRIM
                } else {
                    f32::INFINITY
                };
                let mut cost = [0.0; WIDTH];
                cost[0] = leaf.min(wide);
                let mut fewer = 0;
                for i in 2..=WIDTH {
                    if cost[i - 2] <= dist[i] {
                        cost[i - 1] = cost[i - 2];
                        fewer |= 1 << i;
                    } else {
                        cost[i - 1] = dist[i];
                    }
                }
                Plan {
                    node,
                    start,
                    triangles,
                    cost,
                    fewer,
                    split,
                    wide_cost: wide,
                    children: Some(Box::new([left, right])),
                }
            }
        }
    }

    /// Whether the subtree's one slot is best a leaf of all its primitives
    /// (always, for a binary leaf) rather than a wide node.
    pub fn as_leaf(&self) -> bool {
        self.children.is_none() || self.cost[0] < self.wide_cost
    }

    /// The least cost of the subtree in one slot (as a leaf or a wide node).
    #[cfg(test)]
    pub fn cost_as_slot(&self) -> f32 {
        self.cost[0]
    }

    /// The children of this subtree's binary node as planned (two, for a
    /// binary leaf none).
    pub fn children(&self) -> Option<&[Plan<'a>; 2]> {
        self.children.as_deref()
    }

    /// The slots of the wide node made of this (interior, not a leaf)
    /// subtree: the first `n` entries of the returned array.
    pub fn slots(&self) -> ([&Plan<'a>; WIDTH], usize) {
        let mut slots = [self; WIDTH];
        let mut n = 0;
        self.share(WIDTH, &mut slots, &mut n);
        (slots, n)
    }

    /// Appends the slots of dist(self, j): the two children's shares.
    fn share<'p>(&'p self, j: usize, slots: &mut [&'p Plan<'a>; WIDTH], n: &mut usize) {
        let [left, right] = self.children().expect("a leaf has no slots to share");
        let k = self.split[j] as usize;
        left.gather(k, slots, n);
        right.gather(j - k, slots, n);
    }

    /// Appends the (at most `i`) slots of cost(self, i).
    fn gather<'p>(&'p self, mut i: usize, slots: &mut [&'p Plan<'a>; WIDTH], n: &mut usize) {
        while i > 1 && self.fewer & (1 << i) != 0 {
            i -= 1;
        }
        if i == 1 {
            slots[*n] = self;
            *n += 1;
        } else {
            self.share(i, slots, n);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build::{self, BuildParams};
    use crate::sampling::rng::{hash_words, to_unit_float};
    use crate::scene::Aabb;
    use glam::Vec3;

    /// Small random trees: `n` boxes around `scale`, the first
    /// `triangles` of them triangles and the rest spheres, leaves of at
    /// most two primitives so that the binary tree is deep enough for the
    /// choices to matter. Boxes have half-sizes up to `size` in a cube of
    /// side 10: small ones leave space between siblings (opening a node
    /// pays), large ones overlap (keeping a node whole as one leaf or one
    /// slot pays, so fewer slots than offered are the cheaper plan).
    fn random_tree(
        seed: u32,
        n: usize,
        triangles: u32,
        scale: f32,
        size: f32,
    ) -> (BuildNode, Vec<u32>) {
        let mut draw = 0;
        let mut next = move || {
            draw += 1;
            to_unit_float(hash_words(&[seed, draw]))
        };
        let boxes: Vec<Aabb> = (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let h = Vec3::new(next(), next(), next()) * size + Vec3::splat(0.01);
                Aabb {
                    min: (c - h) * scale,
                    max: (c + h) * scale,
                }
            })
            .collect();
        // A broken generator would make every box alike, and the tests
        // built on these trees would then compare trivial trees.
        assert!(boxes.windows(2).any(|w| w[0] != w[1]), "degenerate fixture");
        let params = BuildParams {
            sah: true,
            bins: 8,
            traversal_cost: 1.0,
            lanes: 1,
            max_leaf: 2,
            top_slots: 0,
        };
        let (root, order) = build::build(&boxes, triangles, params);
        (root.expect("boxes were given"), order)
    }

    /// Every way to take at most `WIDTH` slots from the subtree `plan`:
    /// itself, or a way for each child, side by side.
    fn frontiers<'p, 'a>(plan: &'p Plan<'a>) -> Vec<Vec<&'p Plan<'a>>> {
        let mut all = vec![vec![plan]];
        if let Some([left, right]) = plan.children() {
            for l in frontiers(left) {
                for r in frontiers(right) {
                    if l.len() + r.len() <= WIDTH {
                        all.push(l.iter().chain(&r).copied().collect());
                    }
                }
            }
        }
        all
    }

    /// The least cost of `plan`'s subtree in one slot, by trying every
    /// collapse: as a leaf where allowed (one triangle group, or a binary
    /// leaf as built), or as a wide node over each frontier of its
    /// children. Ids from `triangles` on are spheres, one test each.
    fn exhaustive(plan: &Plan, root_area: f32, order: &[u32], triangles: u32) -> f32 {
        let area = plan.node.bounds().surface_area() / root_area;
        let count = plan.node.count() as usize;
        let prims = &order[plan.start as usize..plan.start as usize + count];
        let all_triangles = prims.iter().all(|&id| id < triangles);
        let leaf = match plan.node {
            BuildNode::Leaf { .. } if all_triangles => {
                return area * C_PRIM * count.div_ceil(TRI_WIDTH) as f32;
            }
            BuildNode::Leaf { .. } => return area * C_PRIM * count as f32,
            BuildNode::Inner { .. } if all_triangles && count <= TRI_WIDTH => area * C_PRIM,
            BuildNode::Inner { .. } => f32::INFINITY,
        };
        leaf.min(area * C_NODE + exhaustive_wide(plan, root_area, order, triangles))
    }

    /// The least cost of the slots of a wide node made of interior `plan`.
    fn exhaustive_wide(plan: &Plan, root_area: f32, order: &[u32], triangles: u32) -> f32 {
        let [left, right] = plan.children().unwrap();
        let mut best = f32::INFINITY;
        for l in frontiers(left) {
            for r in frontiers(right) {
                if l.len() + r.len() <= WIDTH {
                    let c = l
                        .iter()
                        .chain(&r)
                        .map(|p| exhaustive(p, root_area, order, triangles))
                        .sum();
                    best = best.min(c);
                }
            }
        }
        best
    }

    /// Every subtree the plan turns into one leaf holds one kind.
    fn assert_leaves_one_kind(plan: &Plan, order: &[u32], triangles: u32) {
        if let Some(children) = plan.children() {
            if plan.as_leaf() {
                let start = plan.start as usize;
                let prims = &order[start..start + plan.node.count() as usize];
                assert!(prims.iter().all(|&id| id < triangles), "{prims:?}");
            }
            for c in children {
                assert_leaves_one_kind(c, order, triangles);
            }
        }
    }

    #[test]
    fn plan_is_the_least_cost_collapse() {
        // Trees deeper than one wide node, and trees of three to eight
        // boxes, which cannot use all the root's slots.
        let sizes = (0..16).map(|seed| (seed, 18 + seed as usize));
        let small = (16..28).map(|seed| (seed, 3 + seed as usize % 6));
        for (seed, n) in sizes.chain(small) {
            // Half the trees mix in spheres, which never share a leaf.
            let triangles = if seed % 2 == 0 {
                n as u32
            } else {
                n as u32 / 2
            };
            let size = if seed % 4 < 2 { 0.8 } else { 6.0 };
            let (root, order) = random_tree(seed, n, triangles, 1.0, size);
            let plan = Plan::new(&root, triangles, &order);
            let root_area = root.bounds().surface_area();
            let want = C_NODE + exhaustive_wide(&plan, root_area, &order, triangles);
            assert!(
                (plan.wide_cost - want).abs() <= 1e-5 * want,
                "seed {seed}: plan {} vs exhaustive {want}",
                plan.wide_cost
            );
            // The slots the plan hands out cost what it says.
            let (slots, n) = plan.slots();
            let sum: f32 = slots[..n].iter().map(|p| p.cost[0]).sum();
            assert!((C_NODE + sum - plan.wide_cost).abs() <= 1e-5 * plan.wide_cost);
            assert_leaves_one_kind(&plan, &order, triangles);
        }
    }

    /// Coordinates whose box areas overflow f32 still plan (areas are
    /// taken in f64), into two to eight slots.
    #[test]
    fn huge_coordinates_plan() {
        let (root, order) = random_tree(3, 40, 40, 1e30, 0.8);
        let plan = Plan::new(&root, 40, &order);
        assert!(plan.wide_cost.is_finite());
        let (_, n) = plan.slots();
        assert!((2..=WIDTH).contains(&n));
    }
}
