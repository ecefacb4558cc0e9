//! Binary BVH construction: binned SAH and the textbook midpoint split.
//!
//! The builder works on primitive *bounds* only, so triangles and spheres go
//! through the same code. It produces a pointer-based binary tree plus a
//! permutation of primitive ids; [`super::collapse`] and
//! [`super::flatten`] then turn that tree into the wide nodes traversal
//! reads. Keeping the steps apart lets the split heuristics stay simple
//! binary code while the layout is free to be as wide as the SIMD unit.
//!
//! The binned SAH follows Wald, "On fast Construction of SAH-based Bounding
//! Volume Hierarchies" (2007): centroids are dropped into equal-width bins
//! along each axis, and only bin boundaries are evaluated as split planes.
//! A leaf is charged per SIMD group of triangles (`ceil(n/8)·8` tests), so
//! the heuristic fills groups instead of splitting them into half-empty
//! ones. The top of the tree, where one node covers most primitives, scans
//! and bins in parallel chunks; below, subtrees are built in parallel.
//! Primitives whose centroids coincide, and any subtree deeper than 48
//! levels, fall back to median splits, which bounds the depth.

use glam::{BVec3A, Vec3A};
use rayon::prelude::*;

use crate::scene::Aabb;

/// Split strategy plus its tuning knobs.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BuildParams {
    /// Surface area heuristic if true, else midpoint of the longest centroid axis.
    pub sah: bool,
    /// Number of centroid bins per axis for the SAH (at most [`MAX_BINS`]).
    pub bins: usize,
    /// Cost of one node visit relative to one primitive test.
    pub traversal_cost: f32,
    /// Primitives are tested in groups of this many lanes; a leaf costs
    /// `ceil(n / lanes)` group tests of `lanes` primitives each, so the SAH
    /// does not try to make leaves smaller than a SIMD group.
    pub lanes: usize,
    /// Leaves never hold more than this many primitives.
    pub max_leaf: usize,
    /// Slots of the root wide node: the large flat pieces of the scene
    /// (walls, floors) get one each when they fit (see `isolate_large`);
    /// 0 turns this off.
    pub top_slots: usize,
}

impl BuildParams {
    /// The textbook build (`--accel median`): midpoint of the longest
    /// centroid axis, leaves of at most four primitives, nothing set apart.
    pub const MIDPOINT: BuildParams = BuildParams {
        sah: false,
        bins: 0,
        traversal_cost: 0.0,
        lanes: 1,
        max_leaf: 4,
        top_slots: 0,
    };
}

/// Depth after which splits fall back to the object median, which halves
/// the primitive count at each level. This bounds the tree depth (and so the
/// traversal stack) for any input, however adversarial.
const MAX_HEURISTIC_DEPTH: usize = 48;

/// Above this many primitives a node's two subtrees are built in parallel.
const PARALLEL_THRESHOLD: usize = 4096;

/// Above this many primitives a node's bounds and bins are computed by
/// several threads (the top levels would otherwise run on one core).
const PARALLEL_SCAN: usize = 1 << 16;

/// Box with SIMD-friendly (16-byte) corners for the inner loops of the build.
#[derive(Clone, Copy, Debug)]
struct Bounds {
    min: Vec3A,
    max: Vec3A,
}

impl From<&Aabb> for Bounds {
    fn from(b: &Aabb) -> Bounds {
        Bounds {
            min: b.min.into(),
            max: b.max.into(),
        }
    }
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline]
    fn union(self, o: Bounds) -> Bounds {
        Bounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline]
    fn grow(self, p: Vec3A) -> Bounds {
        Bounds {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    fn volume(self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        d.x * d.y * d.z
    }

    /// Half the surface area (the factor 2 cancels in every SAH comparison).
    #[inline]
    fn half_area(self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// `self` where `mask` is set, else `other` (per axis, both corners).
    #[inline]
    fn select(self, mask: BVec3A, other: Bounds) -> Bounds {
        Bounds {
            min: Vec3A::select(mask, self.min, other.min),
            max: Vec3A::select(mask, self.max, other.max),
        }
    }

    fn aabb(self) -> Aabb {
        Aabb {
            min: self.min.into(),
            max: self.max.into(),
        }
    }
}

/// A node of the intermediate binary tree.
pub(crate) enum BuildNode {
    /// Primitives `order[start..start + count]`, all of one kind.
    Leaf {
        bounds: Aabb,
        start: u32,
        count: u32,
    },
    Inner {
        bounds: Aabb,
        /// Primitives below this node.
        count: u32,
        children: Box<[BuildNode; 2]>,
        /// Made by joining the parts `isolate_large` set apart: collapsing
        /// into wide nodes opens these first, so each part gets a slot of
        /// the root.
        joins_parts: bool,
    },
}

impl BuildNode {
    pub fn bounds(&self) -> &Aabb {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Inner { bounds, .. } => bounds,
        }
    }

    /// Primitives below this node.
    pub fn count(&self) -> u32 {
        match self {
            BuildNode::Leaf { count, .. } | BuildNode::Inner { count, .. } => *count,
        }
    }
}

/// Read-only inputs shared by every recursion step.
struct Ctx<'a> {
    bounds: &'a [Bounds],
    centroids: &'a [Vec3A],
    /// Ids below this are triangles, the rest spheres; a leaf never mixes them.
    triangle_count: u32,
    params: BuildParams,
}

/// Builds a binary tree over primitives `0..bounds.len()`. Returns the root
/// (None when there are no primitives) and the leaf order: leaf
/// `start..start + count` refers to `order[start..start + count]`.
pub(crate) fn build(
    bounds: &[Aabb],
    triangle_count: u32,
    params: BuildParams,
) -> (Option<BuildNode>, Vec<u32>) {
    assert!((2..=MAX_BINS).contains(&params.bins) || !params.sah);
    let mut order: Vec<u32> = (0..bounds.len() as u32).collect();
    if bounds.is_empty() {
        return (None, order);
    }
    let bounds: Vec<Bounds> = bounds.par_iter().map(Bounds::from).collect();
    let centroids: Vec<Vec3A> = bounds.par_iter().map(|b| (b.min + b.max) * 0.5).collect();
    let ctx = Ctx {
        bounds: &bounds,
        centroids: &centroids,
        triangle_count,
        params,
    };
    let root = match isolate_large(&ctx, &mut order) {
        Some(parts) => build_parts(&ctx, &mut order, &parts),
        None => build_node(&ctx, &mut order, 0, 0, None),
    };
    (Some(root), order)
}

/// Builds each of `parts` (consecutive ranges of `order`, by length) as its
/// own subtree and joins them in a balanced binary tree, whose nodes the
/// wide layout opens first (`joins_parts`), so each part gets a slot of
/// the root.
fn build_parts(ctx: &Ctx, order: &mut [u32], parts: &[usize]) -> BuildNode {
    let mut nodes = Vec::with_capacity(parts.len());
    let mut rest = order;
    let mut offset = 0;
    // The joins sit above every part: count them as depth.
    let depth = parts.len().next_power_of_two().trailing_zeros() as usize;
    for &len in parts {
        let (part, tail) = rest.split_at_mut(len);
        nodes.push(build_node(ctx, part, offset, depth, None));
        offset += len;
        rest = tail;
    }
    join(nodes)
}

fn join(mut nodes: Vec<BuildNode>) -> BuildNode {
    if nodes.len() == 1 {
        return nodes.pop().unwrap();
    }
    let right = join(nodes.split_off(nodes.len() / 2));
    let left = join(nodes);
    BuildNode::Inner {
        bounds: left.bounds().union(right.bounds()),
        count: left.count() + right.count(),
        children: Box::new([left, right]),
        joins_parts: true,
    }
}

/// A triangle is large if its box's surface area exceeds this fraction of
/// the scene box's.
const LARGE_AREA: f32 = 0.02;

/// A box is flat if its volume is at most this fraction of the scene box's.
/// Large triangles with flat boxes (in an axis plane, or nearly) are
/// clustered into flat pieces while their union stays flat.
const FLAT_VOLUME: f32 = 1e-3;

/// Finds the scene's large flat pieces — the walls, floor and ceiling of a
/// room: large triangles with flat boxes, clustered while their union stays
/// flat — and, if they and the rest fit in `ctx.params.top_slots` subtrees,
/// reorders `order` as [piece 1, piece 2, …, the rest] and returns the
/// lengths of those ranges.
///
/// The SAH prices a box by its surface area, which is the chance that a
/// ray from *outside* enters it. Inside a room every ray starts inside
/// the room, so a leaf holding the walls (whose box is the room) is
/// entered, and its triangles tested, by every ray, while a wall's own flat
/// box is entered only by rays that reach that wall — shadow rays toward
/// a ceiling light never do. The binned SAH keeps the walls together
/// because no single split helps: any two perpendicular walls already span
/// the room. Giving each flat piece its own subtree, and so its own slot
/// of the root, is that missing look-ahead. A large triangle whose box is
/// not flat (a slanted wall) stays with the rest: its box is entered from
/// inside as the room's is. Scenes without large flat triangles (most
/// meshes) are built exactly as before.
fn isolate_large(ctx: &Ctx, order: &mut [u32]) -> Option<Vec<usize>> {
    let slots = ctx.params.top_slots;
    if slots < 2 {
        return None;
    }
    let scene = ctx
        .bounds
        .par_iter()
        .copied()
        .reduce(|| Bounds::EMPTY, Bounds::union);
    let (area, volume) = (scene.half_area(), scene.volume());
    let large: Vec<u32> = (0..ctx.triangle_count)
        .into_par_iter()
        .filter(|&id| {
            let b = ctx.bounds[id as usize];
            b.half_area() > LARGE_AREA * area && b.volume() <= FLAT_VOLUME * volume
        })
        .collect();
    // The rest must not be empty, and a room's worth of large triangles
    // is a few dozen: clustering is cubic in their number.
    if large.is_empty() || large.len() == order.len() || large.len() > 16 * slots {
        return None;
    }
    // Agglomerative clustering: merge the two pieces whose union is
    // flattest while it stays flat.
    let mut pieces: Vec<(Bounds, Vec<u32>)> = large
        .iter()
        .map(|&id| (ctx.bounds[id as usize], vec![id]))
        .collect();
    loop {
        let mut best: Option<(f32, usize, usize)> = None;
        for i in 0..pieces.len() {
            for j in i + 1..pieces.len() {
                let v = pieces[i].0.union(pieces[j].0).volume();
                if v <= FLAT_VOLUME * volume && best.is_none_or(|b| v < b.0) {
                    best = Some((v, i, j));
                }
            }
        }
        let Some((_, i, j)) = best else { break };
        let (b, ids) = pieces.swap_remove(j);
        pieces[i].0 = pieces[i].0.union(b);
        pieces[i].1.extend(ids);
    }
    // Each piece and the rest get a slot of the root, or nothing changes.
    if pieces.len() + 1 > slots {
        return None;
    }
    let mut is_large = vec![false; ctx.bounds.len()];
    let mut parts = Vec::with_capacity(pieces.len() + 1);
    let mut k = 0;
    for (_, ids) in &pieces {
        for &id in ids {
            is_large[id as usize] = true;
            order[k] = id;
            k += 1;
        }
        parts.push(ids.len());
    }
    parts.push(order.len() - k);
    for id in 0..ctx.bounds.len() as u32 {
        if !is_large[id as usize] {
            order[k] = id;
            k += 1;
        }
    }
    Some(parts)
}

/// Bounds of the primitives and of their centroids.
fn scan_bounds(ctx: &Ctx, prims: &[u32]) -> (Bounds, Bounds) {
    let scan = |prims: &[u32]| {
        let (mut b, mut c) = (Bounds::EMPTY, Bounds::EMPTY);
        for &p in prims {
            b = b.union(ctx.bounds[p as usize]);
            c = c.grow(ctx.centroids[p as usize]);
        }
        (b, c)
    };
    if prims.len() > PARALLEL_SCAN {
        prims.par_chunks(PARALLEL_SCAN / 4).map(scan).reduce(
            || (Bounds::EMPTY, Bounds::EMPTY),
            |a, b| (a.0.union(b.0), a.1.union(b.1)),
        )
    } else {
        scan(prims)
    }
}

/// How a node is split: the size of the left part, and the (primitive,
/// centroid) bounds of both parts when the partition computed them.
struct Split {
    mid: usize,
    sides: Option<[(Bounds, Bounds); 2]>,
}

impl From<usize> for Split {
    fn from(mid: usize) -> Split {
        Split { mid, sides: None }
    }
}

/// `known`: the (primitive, centroid) bounds of `prims`, if the parent's
/// partition already computed them.
fn build_node(
    ctx: &Ctx,
    prims: &mut [u32],
    offset: usize,
    depth: usize,
    known: Option<(Bounds, Bounds)>,
) -> BuildNode {
    let n = prims.len();
    let (bounds, cbounds) = known.unwrap_or_else(|| scan_bounds(ctx, prims));

    let Some(Split { mid, sides }) = choose_split(ctx, prims, bounds, cbounds, depth) else {
        return make_leaf(ctx, prims, offset, bounds);
    };
    let [ls, rs] = match sides {
        Some([l, r]) => [Some(l), Some(r)],
        None => [None, None],
    };

    let (left, right) = prims.split_at_mut(mid);
    let (l, r) = if n > PARALLEL_THRESHOLD {
        rayon::join(
            || build_node(ctx, left, offset, depth + 1, ls),
            || build_node(ctx, right, offset + mid, depth + 1, rs),
        )
    } else {
        (
            build_node(ctx, left, offset, depth + 1, ls),
            build_node(ctx, right, offset + mid, depth + 1, rs),
        )
    };
    BuildNode::Inner {
        bounds: bounds.aabb(),
        count: n as u32,
        children: Box::new([l, r]),
        joins_parts: false,
    }
}

/// Per-axis bin boxes and primitive counts.
#[derive(Clone, Copy)]
struct Bins {
    bounds: [[Bounds; MAX_BINS]; 3],
    count: [[u32; MAX_BINS]; 3],
}

impl Bins {
    const EMPTY: Bins = Bins {
        bounds: [[Bounds::EMPTY; MAX_BINS]; 3],
        count: [[0; MAX_BINS]; 3],
    };

    fn merge(mut self, o: &Bins) -> Bins {
        for a in 0..3 {
            for k in 0..MAX_BINS {
                self.bounds[a][k] = self.bounds[a][k].union(o.bounds[a][k]);
                self.count[a][k] += o.count[a][k];
            }
        }
        self
    }
}

/// Partitions `prims` for a split and returns the size of the left part, or
/// None if this node should be a leaf.
fn choose_split(
    ctx: &Ctx,
    prims: &mut [u32],
    bounds: Bounds,
    cbounds: Bounds,
    depth: usize,
) -> Option<Split> {
    let n = prims.len();
    let p = &ctx.params;
    if n <= 1 {
        return None;
    }
    let extent = cbounds.max - cbounds.min;
    let axis = extent.max_position();
    // All centroids coincide: no plane separates them. Small sets become a
    // leaf; large ones are halved arbitrarily to respect `max_leaf`.
    if extent[axis] <= 0.0 {
        return if n <= p.max_leaf {
            None
        } else {
            Some((n / 2).into())
        };
    }
    if depth >= MAX_HEURISTIC_DEPTH {
        return (n > p.max_leaf).then(|| object_median(ctx, prims, axis).into());
    }

    if !p.sah {
        // Textbook midpoint split; degenerate outcomes fall back to the median.
        if n <= p.max_leaf {
            return None;
        }
        let plane = 0.5 * (cbounds.min[axis] + cbounds.max[axis]);
        let mid = partition(prims, |id| ctx.centroids[id as usize][axis] < plane);
        return if mid == 0 || mid == n {
            Some(object_median(ctx, prims, axis).into())
        } else {
            Some(mid.into())
        };
    }

    // Binned SAH. Costs are in units of one primitive test, scaled by the
    // parent's surface area (which cancels when comparing the options).
    let bins = p.bins;
    // Axes without extent get scale 0: everything lands in bin 0 and no
    // split along them is ever valid (one side would be empty).
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(bins as f32 * (1.0 - f32::EPSILON)) / extent,
        Vec3A::ZERO,
    );
    let bin_index = |c: Vec3A| -> [usize; 3] {
        let k = ((c - cbounds.min) * scale).min(Vec3A::splat((bins - 1) as f32));
        // The three truncations as one vector instruction: k lies in
        // [0, bins − 1] (c ≥ cbounds.min), where `as usize` lane by lane
        // adds saturation checks (15% of the build's time). The `max`
        // keeps what a NaN becomes (i32::MIN) a valid bin, as `as` would.
        let k = wide::f32x4::from(k.extend(0.0).to_array()).fast_trunc_int();
        let k = k.max(wide::i32x4::ZERO).to_array();
        [k[0] as usize, k[1] as usize, k[2] as usize]
    };
    let fill = |prims: &[u32]| {
        let mut bin = Bins::EMPTY;
        for &id in prims {
            let k = bin_index(ctx.centroids[id as usize]);
            let b = ctx.bounds[id as usize];
            for (a, &k) in k.iter().enumerate() {
                bin.count[a][k] += 1;
                bin.bounds[a][k] = bin.bounds[a][k].union(b);
            }
        }
        bin
    };
    let bin = if n > PARALLEL_SCAN {
        prims
            .par_chunks(PARALLEL_SCAN / 4)
            .map(fill)
            .reduce(|| Bins::EMPTY, |a, b| a.merge(&b))
    } else {
        fill(prims)
    };

    let group_cost = |count: u32| -> f32 { count.div_ceil(p.lanes as u32) as f32 * p.lanes as f32 };
    let mut best = (f32::INFINITY, 0usize, 0usize); // (cost, axis, split bin)
    for a in 0..3 {
        if extent[a] <= 0.0 {
            continue;
        }
        // Sweep from the right, remembering the area·count of every suffix.
        let mut right_cost = [0.0f32; MAX_BINS];
        let mut acc = Bounds::EMPTY;
        let mut count = 0;
        for k in (1..bins).rev() {
            acc = acc.union(bin.bounds[a][k]);
            count += bin.count[a][k];
            right_cost[k] = acc.half_area() * group_cost(count);
        }
        let mut acc = Bounds::EMPTY;
        let mut count = 0;
        for k in 0..bins - 1 {
            acc = acc.union(bin.bounds[a][k]);
            count += bin.count[a][k];
            let cost = acc.half_area() * group_cost(count) + right_cost[k + 1];
            if cost < best.0 {
                best = (cost, a, k + 1);
            }
        }
    }

    let area = bounds.half_area();
    let split_cost = p.traversal_cost * area + best.0;
    let leaf_cost = area * group_cost(n as u32);
    if n <= p.max_leaf && leaf_cost <= split_cost {
        return None;
    }
    let (_, a, k) = best;
    // Partition, collecting both sides' bounds on the way (saves the
    // children a pass over their primitives). Which side a primitive goes
    // to is a coin toss to the branch predictor, so nothing here branches
    // on it: a Lomuto partition with an unconditional swap (a primitive
    // for the right side swaps with another one, or with itself), and
    // both sides' bounds grown, selects keeping the grown one only on
    // the primitive's side.
    let mut i = 0;
    let mut sides = [(Bounds::EMPTY, Bounds::EMPTY); 2];
    for j in 0..n {
        let id = prims[j];
        let (b, c) = (ctx.bounds[id as usize], ctx.centroids[id as usize]);
        let left = bin_index(c)[a] < k;
        prims[j] = prims[i];
        prims[i] = id;
        i += left as usize;
        let keep = BVec3A::splat(left);
        let [l, r] = &mut sides;
        l.0 = l.0.union(b).select(keep, l.0);
        l.1 = l.1.grow(c).select(keep, l.1);
        r.0 = r.0.select(keep, r.0.union(b));
        r.1 = r.1.select(keep, r.1.grow(c));
    }
    if i == 0 || i == n {
        Some(object_median(ctx, prims, axis).into())
    } else {
        Some(Split {
            mid: i,
            sides: Some(sides),
        })
    }
}

/// Upper bound on `BuildParams::bins`.
pub(crate) const MAX_BINS: usize = 32;

/// Splits at the median centroid along `axis` (`n / 2` on each side).
fn object_median(ctx: &Ctx, prims: &mut [u32], axis: usize) -> usize {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |&a, &b| {
        ctx.centroids[a as usize][axis].total_cmp(&ctx.centroids[b as usize][axis])
    });
    mid
}

/// In-place partition: elements satisfying `pred` move to the front.
/// Returns their count.
fn partition(prims: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    let mut j = prims.len();
    while i < j {
        if pred(prims[i]) {
            i += 1;
        } else {
            j -= 1;
            prims.swap(i, j);
        }
    }
    i
}

/// A leaf, or two leaves if the primitives mix triangles and spheres (so
/// every leaf has one kind and traversal never branches per primitive).
fn make_leaf(ctx: &Ctx, prims: &mut [u32], offset: usize, bounds: Bounds) -> BuildNode {
    let t = ctx.triangle_count;
    let tris = partition(prims, |id| id < t);
    if tris == 0 || tris == prims.len() {
        return BuildNode::Leaf {
            bounds: bounds.aabb(),
            start: offset as u32,
            count: prims.len() as u32,
        };
    }
    let leaf = |part: &[u32], start: usize| {
        let mut b = Bounds::EMPTY;
        for &id in part {
            b = b.union(ctx.bounds[id as usize]);
        }
        BuildNode::Leaf {
            bounds: b.aabb(),
            start: start as u32,
            count: part.len() as u32,
        }
    };
    let l = leaf(&prims[..tris], offset);
    let r = leaf(&prims[tris..], offset + tris);
    BuildNode::Inner {
        bounds: bounds.aabb(),
        count: prims.len() as u32,
        children: Box::new([l, r]),
        joins_parts: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The primitive ids in `node`'s leaves, appended to `seen`.
    fn leaf_ids(node: &BuildNode, order: &[u32], seen: &mut Vec<u32>) {
        match node {
            BuildNode::Leaf { start, count, .. } => {
                seen.extend_from_slice(&order[*start as usize..(*start + *count) as usize])
            }
            BuildNode::Inner { children, .. } => {
                leaf_ids(&children[0], order, seen);
                leaf_ids(&children[1], order, seen);
            }
        }
    }

    /// Uniform numbers in [0, 1) for the tests' random inputs.
    struct Xorshift(u64);

    impl Xorshift {
        fn next(&mut self) -> f32 {
            let s = &mut self.0;
            *s ^= *s << 13;
            *s ^= *s >> 7;
            *s ^= *s << 17;
            (*s >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// Checks that every node's box is exactly the union of its
    /// primitives' boxes (tight: a looser box costs rays, a smaller one
    /// loses hits) and its count their number; returns the box.
    fn assert_tight(node: &BuildNode, order: &[u32], prims: &[Aabb]) -> Aabb {
        let (union, count) = match node {
            BuildNode::Leaf { start, count, .. } => {
                let ids = &order[*start as usize..(*start + *count) as usize];
                let union = ids
                    .iter()
                    .map(|&id| prims[id as usize])
                    .reduce(|a, b| a.union(&b))
                    .expect("an empty leaf");
                (union, *count)
            }
            BuildNode::Inner { children, .. } => {
                let [l, r] = [0, 1].map(|k| assert_tight(&children[k], order, prims));
                (l.union(&r), children[0].count() + children[1].count())
            }
        };
        assert_eq!(*node.bounds(), union);
        assert_eq!(node.count(), count);
        union
    }

    #[test]
    fn every_primitive_in_exactly_one_leaf() {
        let bounds: Vec<Aabb> = (0..10_000)
            .map(|i| {
                let p = Vec3::new((i % 17) as f32, (i % 31) as f32 * 0.5, (i / 100) as f32);
                Aabb {
                    min: p,
                    max: p + Vec3::ONE,
                }
            })
            .collect();
        for sah in [false, true] {
            let params = BuildParams {
                sah,
                bins: 16,
                traversal_cost: 1.0,
                lanes: 4,
                max_leaf: 8,
                top_slots: 8,
            };
            let (root, order) = build(&bounds, 5000, params);
            let root = root.unwrap();
            let mut seen = Vec::new();
            leaf_ids(&root, &order, &mut seen);
            seen.sort();
            assert_eq!(seen, (0..10_000).collect::<Vec<u32>>());
            assert_tight(&root, &order, &bounds);
        }
    }

    /// The textbook build splits every node at the midpoint of its
    /// centroids' longest axis (the object median only when that leaves a
    /// side empty) and stops at four primitives or fewer.
    #[test]
    fn midpoint_build_splits_at_the_centroid_midpoint_into_leaves_of_four() {
        let mut rng = Xorshift(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.next();
        let bounds: Vec<Aabb> = (0..3000)
            .map(|_| {
                // Clustered along x so that midpoints and medians differ.
                let p = Vec3::new(next().powi(3) * 8.0, next() * 2.0, next());
                Aabb {
                    min: p,
                    max: p + Vec3::splat(0.01 * next()),
                }
            })
            .collect();
        let centroid = |id: u32| bounds[id as usize].center();
        let (root, order) = build(&bounds, bounds.len() as u32, BuildParams::MIDPOINT);
        let (mut inner, mut midpoint) = (0, 0);
        let mut stack = vec![root.as_ref().unwrap()];
        while let Some(node) = stack.pop() {
            match node {
                BuildNode::Leaf { count, .. } => assert!(*count <= 4, "leaf of {count}"),
                BuildNode::Inner {
                    children, count, ..
                } => {
                    assert!(*count > 4, "a node of {count} was split");
                    let (mut left, mut right) = (Vec::new(), Vec::new());
                    leaf_ids(&children[0], &order, &mut left);
                    leaf_ids(&children[1], &order, &mut right);
                    let all = left.iter().chain(&right).map(|&id| centroid(id));
                    let (lo, hi) = all.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| {
                        (lo.min(c), hi.max(c))
                    });
                    let axis = (hi - lo).max_position();
                    let plane = 0.5 * (lo[axis] + hi[axis]);
                    inner += 1;
                    if left.iter().all(|&id| centroid(id)[axis] < plane)
                        && right.iter().all(|&id| centroid(id)[axis] >= plane)
                    {
                        midpoint += 1;
                    } else {
                        // The fallback: halves by count along the same axis.
                        assert!(left.len().abs_diff(right.len()) <= 1);
                    }
                    stack.extend(children.iter());
                }
            }
        }
        assert!(
            midpoint * 10 >= inner * 9,
            "{midpoint} of {inner} splits at the midpoint"
        );
    }

    /// Leaves of `node` as (bounds, primitive ids), left to right.
    fn leaves(node: &BuildNode, order: &[u32], out: &mut Vec<(Aabb, Vec<u32>)>) {
        match node {
            BuildNode::Leaf {
                bounds,
                start,
                count,
            } => out.push((
                *bounds,
                order[*start as usize..(*start + *count) as usize].to_vec(),
            )),
            BuildNode::Inner { children, .. } => {
                leaves(&children[0], order, out);
                leaves(&children[1], order, out);
            }
        }
    }

    /// Bounds of the leaf holding exactly wall `wall`'s two triangles
    /// (ids `2·wall`, `2·wall + 1`, see [`room`]), if there is one.
    fn wall_leaf(leaves: &[(Aabb, Vec<u32>)], wall: u32) -> Option<Aabb> {
        leaves.iter().find_map(|(b, ids)| {
            let mut ids = ids.clone();
            ids.sort();
            (ids == [2 * wall, 2 * wall + 1]).then_some(*b)
        })
    }

    /// A room: floor, ceiling and three walls, two triangles each (ids
    /// 0..10, in that order), and 200 small triangles (a mesh inside).
    fn room() -> Vec<Aabb> {
        let wall = |min: [f32; 3], max: [f32; 3]| Aabb {
            min: Vec3::from(min),
            max: Vec3::from(max),
        };
        let planes = [
            wall([-1.0, 0.0, -1.0], [1.0, 0.0, 1.0]),
            wall([-1.0, 1.5, -1.0], [1.0, 1.5, 1.0]),
            wall([-1.0, 0.0, -1.0], [-1.0, 1.5, 1.0]),
            wall([1.0, 0.0, -1.0], [1.0, 1.5, 1.0]),
            wall([-1.0, 0.0, -1.0], [1.0, 1.5, -1.0]),
        ];
        let mut bounds: Vec<Aabb> = planes.iter().flat_map(|&p| [p, p]).collect();
        for i in 0..200 {
            let p = Vec3::new((i % 10) as f32 * 0.03, 0.2 + (i / 10) as f32 * 0.02, 0.1);
            bounds.push(Aabb {
                min: p,
                max: p + Vec3::splat(0.02),
            });
        }
        bounds
    }

    fn sah(top_slots: usize) -> BuildParams {
        BuildParams {
            sah: true,
            bins: 16,
            traversal_cost: 2.0,
            lanes: 8,
            max_leaf: 8,
            top_slots,
        }
    }

    #[test]
    fn walls_of_a_room_get_leaves_of_their_own() {
        let bounds = room();
        let (root, order) = build(&bounds, bounds.len() as u32, sah(8));
        let mut found = Vec::new();
        leaves(&root.unwrap(), &order, &mut found);
        // Each wall is a leaf holding exactly its two triangles, with the
        // wall's flat box.
        for wall in 0..5u32 {
            let b = wall_leaf(&found, wall)
                .unwrap_or_else(|| panic!("wall {wall} shares a leaf: {found:?}"));
            assert_eq!(b, bounds[2 * wall as usize]);
        }
        // Without the isolation, the SAH puts walls together in one
        // room-sized leaf (the case this exists for).
        let (root, order) = build(&bounds, bounds.len() as u32, sah(0));
        let mut plain = Vec::new();
        leaves(&root.unwrap(), &order, &mut plain);
        assert!(
            plain
                .iter()
                .any(|(_, l)| l.iter().filter(|&&id| id < 10).count() > 2),
            "plain SAH now separates the walls itself: {plain:?}"
        );
    }

    #[test]
    fn isolation_with_spheres_and_slanted_triangles() {
        // Spheres (ids after the triangles) stay in the rest; a large
        // slanted triangle (its box is not flat) too; every primitive is
        // still in exactly one leaf; the walls still get leaves of their own.
        let mut bounds = room();
        bounds.push(Aabb {
            min: Vec3::new(-0.9, 0.1, -0.9),
            max: Vec3::new(0.9, 1.4, 0.9),
        });
        let triangles = bounds.len() as u32;
        for k in 0..5 {
            let c = Vec3::new(0.1 * k as f32, 0.5, -0.2);
            bounds.push(Aabb {
                min: c - Vec3::splat(0.05),
                max: c + Vec3::splat(0.05),
            });
        }
        let (root, order) = build(&bounds, triangles, sah(8));
        let mut seen = Vec::new();
        leaf_ids(root.as_ref().unwrap(), &order, &mut seen);
        seen.sort();
        assert_eq!(seen, (0..bounds.len() as u32).collect::<Vec<u32>>());
        let mut found = Vec::new();
        leaves(&root.unwrap(), &order, &mut found);
        for wall in 0..5u32 {
            assert!(
                wall_leaf(&found, wall).is_some(),
                "wall {wall} shares a leaf"
            );
        }
        // The parts: the five walls, then everything else.
        let parts = isolated_parts(&bounds, triangles, 8).unwrap();
        let lengths: Vec<usize> = parts.iter().map(Vec::len).collect();
        assert_eq!(lengths, [2, 2, 2, 2, 2, bounds.len() - 10]);
        let mut pieces = parts[..5].concat();
        pieces.sort();
        assert_eq!(pieces, (0..10).collect::<Vec<u32>>());
    }

    /// The parts `isolate_large` makes of `bounds` (ids below
    /// `triangles` are triangles) with `slots` root slots, each as sorted
    /// ids; the rest last.
    fn isolated_parts(bounds: &[Aabb], triangles: u32, slots: usize) -> Option<Vec<Vec<u32>>> {
        let bounds: Vec<Bounds> = bounds.iter().map(Bounds::from).collect();
        let ctx = Ctx {
            bounds: &bounds,
            centroids: &[],
            triangle_count: triangles,
            params: sah(slots),
        };
        let mut order: Vec<u32> = (0..bounds.len() as u32).collect();
        let parts = isolate_large(&ctx, &mut order)?;
        let mut rest = &order[..];
        Some(
            parts
                .iter()
                .map(|&len| {
                    let (part, tail) = rest.split_at(len);
                    rest = tail;
                    let mut part = part.to_vec();
                    part.sort();
                    part
                })
                .collect(),
        )
    }

    #[test]
    fn flat_pieces_are_clustered_flattest_first_while_flat() {
        // The room's floor tilted by a quarter millimetre over its 2 m:
        // its box holds 1e-3 m³, a sixth of the flat limit (1e-3 of the
        // room's 6 m³); still a piece of its own.
        let mut bounds = room();
        for b in &mut bounds[..2] {
            b.max.y = 0.00025;
        }
        let mut parts = isolated_parts(&bounds, bounds.len() as u32, 8).unwrap();
        parts[..5].sort();
        let walls: Vec<Vec<u32>> = (0..5).map(|w| vec![2 * w, 2 * w + 1]).collect();
        assert_eq!(parts[..5], walls[..]);

        // Three floor-sized layers A (id 1), B (id 10) and C (id 0) at
        // heights 0, 1 mm and 2.2 mm: A with B or B with C is flat (4.0
        // and 4.8 dm³), all three are not. The flattest pair merges first,
        // and then C cannot join.
        let mut bounds = room();
        let layer = |y: f32| Aabb {
            min: Vec3::new(-1.0, y, -1.0),
            max: Vec3::new(1.0, y, 1.0),
        };
        bounds[0] = layer(0.0022);
        bounds[1] = layer(0.0);
        bounds.insert(10, layer(0.001));
        let parts = isolated_parts(&bounds, bounds.len() as u32, 8).unwrap();
        assert!(parts.contains(&vec![1, 10]), "{parts:?}");
        assert!(parts.contains(&vec![0]), "{parts:?}");

        // A floor alone takes two slots: itself and the rest.
        let floor_only: Vec<Aabb> = room()
            .into_iter()
            .enumerate()
            .filter(|&(i, _)| !(2..10).contains(&i))
            .map(|(_, b)| b)
            .collect();
        let parts = isolated_parts(&floor_only, 202, 2).unwrap();
        assert_eq!(parts[0], [0, 1]);
        assert_eq!(parts[1].len(), 200);
        assert_eq!(isolated_parts(&floor_only, 202, 1), None);
    }

    #[test]
    fn isolation_keeps_to_the_root_slots() {
        // Five walls and the rest fit in six slots exactly...
        let bounds = room();
        let (_, order) = build(&bounds, bounds.len() as u32, sah(6));
        let (_, plain_order) = build(&bounds, bounds.len() as u32, sah(0));
        assert_ne!(order, plain_order);
        // ...but not in five: the build is the plain SAH one.
        let (root, order) = build(&bounds, bounds.len() as u32, sah(5));
        let (plain, plain_order) = build(&bounds, bounds.len() as u32, sah(0));
        assert_eq!(order, plain_order);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        leaves(&root.unwrap(), &order, &mut a);
        leaves(&plain.unwrap(), &plain_order, &mut b);
        assert_eq!(a.len(), b.len());
    }

    /// The SAH's price of a leaf of `n` primitives per unit of half area:
    /// whole SIMD groups.
    fn group_cost(n: usize, params: &BuildParams) -> f32 {
        (n.div_ceil(params.lanes) * params.lanes) as f32
    }

    /// Half the surface area, computed here apart from the builder's.
    fn half_area(b: &Aabb) -> f32 {
        let d = b.diagonal();
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// The least cost of splitting `prims` into the first k and the rest
    /// of their centroid order along some axis, between distinct
    /// centroids: a full sweep, which sees every split the binned SAH can
    /// (and more, unless each bin holds one distinct centroid).
    fn full_sweep_cost(prims: &[Aabb], params: &BuildParams) -> f32 {
        let n = prims.len();
        let mut best = f32::INFINITY;
        for axis in 0..3 {
            let mut sorted = prims.to_vec();
            sorted.sort_by(|a, b| a.center()[axis].total_cmp(&b.center()[axis]));
            let mut suffix = sorted.clone();
            for k in (0..n - 1).rev() {
                suffix[k] = suffix[k].union(&suffix[k + 1]);
            }
            let mut prefix = sorted[0];
            for k in 1..n {
                if sorted[k].center()[axis] != sorted[k - 1].center()[axis] {
                    let cost = half_area(&prefix) * group_cost(k, params)
                        + half_area(&suffix[k]) * group_cost(n - k, params);
                    best = best.min(cost);
                }
                prefix = prefix.union(&sorted[k]);
            }
        }
        best
    }

    /// The binned SAH's root decision against a full sweep, on inputs whose
    /// centroids fall one per bin on every axis (a random permutation of
    /// the 32 bin centres per axis, at a random spacing; boxes of random
    /// extent around them; the last one on some axis 30 times as large, so
    /// that peeling it off is often best), where the two see the same
    /// splits: the root is split where the cost is least, and is a leaf
    /// exactly when that costs no more than splitting (traversal cost
    /// included), with every knob varied. Two trials repeat each box
    /// enough times to take the parallel binning.
    #[test]
    fn sah_root_split_is_the_least_cost_one_and_a_leaf_only_when_that_is_cheaper() {
        const N: usize = 32;
        let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
        let permutation = |rng: &mut Xorshift| {
            let mut p: Vec<usize> = (0..N).collect();
            for i in (1..N).rev() {
                p.swap(i, (rng.next() * (i + 1) as f32) as usize);
            }
            p
        };
        let (mut splits, mut leaves) = (0, 0);
        for trial in 0..300 {
            let axes = [0, 1, 2].map(|_| permutation(&mut rng));
            let spacing = [0, 1, 2].map(|_| 0.25 + 4.0 * rng.next());
            let copies = if trial < 2 { PARALLEL_SCAN / N + 50 } else { 1 };
            let prims: Vec<Aabb> = (0..N)
                .flat_map(|i| {
                    let centre =
                        Vec3::from([0, 1, 2].map(|a| (axes[a][i] as f32 + 0.5) * spacing[a]));
                    let mut half = Vec3::from([0, 1, 2].map(|a| 3.0 * spacing[a] * rng.next()));
                    if axes[trial % 3][i] == N - 1 {
                        half *= 30.0;
                    }
                    let b = Aabb {
                        min: centre - half,
                        max: centre + half,
                    };
                    std::iter::repeat_n(b, copies)
                })
                .collect();
            let n = prims.len();
            let params = BuildParams {
                sah: true,
                bins: N,
                traversal_cost: 64.0 * rng.next(),
                lanes: [1, 4, 8][trial % 3],
                max_leaf: if trial % 2 == 0 { N } else { 8 },
                top_slots: 0,
            };
            let (root, order) = build(&prims, n as u32, params);
            let root = root.unwrap();
            assert_tight(&root, &order, &prims);
            let best = full_sweep_cost(&prims, &params);
            let area = half_area(root.bounds());
            let split_cost = params.traversal_cost * area + best;
            let leaf_cost = area * group_cost(n, &params);
            let what = format!("trial {trial}, {params:?}");
            match &root {
                BuildNode::Leaf { .. } => {
                    assert!(params.max_leaf >= n, "{what}: a leaf of more than max_leaf");
                    assert!(
                        leaf_cost <= split_cost,
                        "{what}: a leaf costlier than a split"
                    );
                    leaves += 1;
                }
                BuildNode::Inner { children, .. } => {
                    let cost: f32 = children
                        .iter()
                        .map(|c| half_area(c.bounds()) * group_cost(c.count() as usize, &params))
                        .sum();
                    assert!(
                        (cost - best).abs() <= 1e-5 * best,
                        "{what}: split cost {cost}, the least is {best}"
                    );
                    if params.max_leaf >= n {
                        assert!(
                            leaf_cost > split_cost,
                            "{what}: split though a leaf is cheaper"
                        );
                    }
                    splits += 1;
                }
            }
        }
        // Both outcomes are exercised.
        assert!(
            splits >= 50 && leaves >= 20,
            "{splits} splits, {leaves} leaves"
        );
    }

    /// The whole tree's SAH cost (per unit of the root's half area): node
    /// visits at the traversal cost, leaves at their group cost.
    fn tree_cost(node: &BuildNode, params: &BuildParams) -> f32 {
        let here = half_area(node.bounds());
        match node {
            BuildNode::Leaf { count, .. } => here * group_cost(*count as usize, params),
            BuildNode::Inner { children, .. } => {
                here * params.traversal_cost
                    + tree_cost(&children[0], params)
                    + tree_cost(&children[1], params)
            }
        }
    }

    /// Below the root the bins no longer hold one centroid each, so the
    /// greedy binned build is checked by its result: on clustered input,
    /// large enough to use the parallel scan and subtree builds, its tree
    /// costs far less than the midpoint tree by the SAH's own measure.
    #[test]
    fn sah_tree_costs_well_below_the_midpoint_tree() {
        let mut rng = Xorshift(0x1234_5678_9abc_def1);
        let prims: Vec<Aabb> = (0..(PARALLEL_SCAN + 5000))
            .map(|_| {
                // Dense clusters on a sparse lattice, boxes of mixed size.
                let cell = Vec3::new(
                    (rng.next() * 6.0).floor() * 10.0,
                    (rng.next() * 3.0).floor() * 10.0,
                    0.0,
                );
                let p = cell + Vec3::new(rng.next(), rng.next(), rng.next()).powf(3.0);
                let size = 0.001 + 0.05 * rng.next().powi(4);
                Aabb {
                    min: p,
                    max: p + Vec3::splat(size),
                }
            })
            .collect();
        let n = prims.len() as u32;
        let params = sah(0);
        let (sah_root, order) = build(&prims, n, params);
        let sah_root = sah_root.unwrap();
        assert_tight(&sah_root, &order, &prims);
        let (mid_root, _) = build(&prims, n, BuildParams::MIDPOINT);
        let (sah_cost, mid_cost) = (
            tree_cost(&sah_root, &params),
            tree_cost(&mid_root.unwrap(), &params),
        );
        assert!(
            sah_cost < 0.8 * mid_cost,
            "SAH tree {sah_cost}, midpoint tree {mid_cost}"
        );
    }

    /// Depth of the deepest leaf below `node` (a root leaf has depth 0),
    /// checking on the way that no leaf holds more than `max_leaf`
    /// primitives and that, past the heuristic depth limit, no node
    /// holding at most that many is split.
    fn depth_checked(node: &BuildNode, depth: usize, max_leaf: usize) -> usize {
        let small = node.count() as usize <= max_leaf;
        match node {
            BuildNode::Leaf { .. } => {
                assert!(small, "a leaf of {} at depth {depth}", node.count());
                depth
            }
            BuildNode::Inner { children, .. } => {
                assert!(
                    !small || depth < MAX_HEURISTIC_DEPTH,
                    "{} split at depth {depth}",
                    node.count()
                );
                children
                    .iter()
                    .map(|c| depth_checked(c, depth + 1, max_leaf))
                    .max()
                    .unwrap()
            }
        }
    }

    /// Centroids doubling away from the origin on both sides make the
    /// midpoint split peel off one primitive per level (all but the
    /// farthest lie within half the range), on the right on one side and
    /// on the left on the other; past `MAX_HEURISTIC_DEPTH` the object
    /// median takes over, so the depth stays within that plus log2(n).
    /// With a cluster of more than 4096 primitives on each side the
    /// peeling runs through the parallel subtree builds, with a small one
    /// through the serial ones.
    #[test]
    fn depth_is_bounded_for_adversarial_input() {
        let mut rng = Xorshift(0x0bad_5eed_0bad_5eed);
        for cluster in [5000, 100] {
            let mut prims = Vec::new();
            for side in [1.0f32, -1.0] {
                prims.extend((0..cluster).map(|_| {
                    let p = Vec3::new(side * rng.next(), rng.next(), rng.next());
                    Aabb {
                        min: p,
                        max: p + Vec3::splat(0.01),
                    }
                }));
                prims.extend((1..=100).map(|i| {
                    let p = Vec3::new(side * 2f32.powi(i), 0.5, 0.5);
                    Aabb { min: p, max: p }
                }));
            }
            let n = prims.len();
            let params = BuildParams::MIDPOINT;
            let (root, order) = build(&prims, n as u32, params);
            let root = root.unwrap();
            assert_tight(&root, &order, &prims);
            let depth = depth_checked(&root, 0, params.max_leaf);
            let bound = MAX_HEURISTIC_DEPTH + n.ilog2() as usize + 2;
            // The input does reach the limit: the peeling goes past it.
            assert!(
                (MAX_HEURISTIC_DEPTH..=bound).contains(&depth),
                "cluster {cluster}: depth {depth}, bound {bound}"
            );
        }
    }

    /// Centroids one float apart: the midpoint of their range rounds onto
    /// one of them, leaving a side empty, and the build falls back to the
    /// median instead of recursing on the same node for ever.
    #[test]
    fn midpoint_build_terminates_on_centroids_one_ulp_apart() {
        let x = [1.0f32, 1.0f32.next_up()];
        let prims: Vec<Aabb> = (0..40)
            .map(|i| {
                let p = Vec3::new(x[i % 2], 0.0, 0.0);
                Aabb { min: p, max: p }
            })
            .collect();
        for params in [BuildParams::MIDPOINT, sah(0)] {
            let (root, order) = build(&prims, 40, params);
            let root = root.unwrap();
            assert_tight(&root, &order, &prims);
            let mut found = Vec::new();
            leaves(&root, &order, &mut found);
            assert!(found.iter().all(|(_, ids)| ids.len() <= params.max_leaf));
        }
    }
}
