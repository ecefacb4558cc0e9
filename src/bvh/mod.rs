//! Bounding volume hierarchy: build, layout, traversal.
//!
//! [`Bvh::build`] turns a scene's [`Geometry`] into an acceleration
//! structure that answers two batch queries over structure-of-arrays
//! [`Rays`]: [`Bvh::intersect`] (closest hit) and [`Bvh::occluded`] (any
//! hit). Queries are single-threaded over one batch, allocate nothing per
//! ray and share nothing mutable, so callers parallelise across batches.
//!
//! The pipeline, one module per step:
//!
//! * `build`: a binary tree by binned SAH (or the textbook
//!   midpoint split) over primitive bounds, triangles and spheres alike,
//!   with rayon for the subtrees and the scans of large nodes.
//! * `collapse`: which binary nodes become the slots of
//!   each wide node — the collapse of least SAH cost, by dynamic
//!   programming over the binary tree.
//! * `flatten`: lay that out as [`WIDTH`]-wide nodes whose
//!   child boxes are stored lane-wise (one SIMD register per slab plane),
//!   with 32-bit child references, and copy the triangles, in leaf order,
//!   into groups of [`TRI_WIDTH`] in structure-of-arrays form. The `Bvh`
//!   owns this copy and never looks at the `Geometry` again.
//! * `traverse`: the batch is first culled [`WIDTH`]
//!   rays at a time against the scene bounds, then each surviving ray walks
//!   the tree with a conservative (Ize 2013) slab test: nearest child first
//!   for closest hits, in slot order for any hits.
//! * `packet`: closest hit — when those [`WIDTH`] rays (or
//!   those of two neighbouring slots, on AVX-512) all point into one octant
//!   (the samples of a pixel) they walk the tree together instead, one lane
//!   per ray, with the same answers bit for bit.
//! * `bundle`: any hit — two or more rays of a slot walk
//!   the tree together, each tested alone at every node it enters, sharing
//!   the walk's control (the shadow rays of one path vertex share most of
//!   the top of the tree).
//! * `triangle`: watertight ray/triangle test (Woop,
//!   Benthin, Wald 2013), [`TRI_WIDTH`] triangles per SIMD test.
//! * `sphere`: numerically stable ray/sphere test; spheres
//!   live in their own leaves, so scenes without spheres never pay for them.
//!
//! Memory: a wide node is 256 bytes (8 × 6 bounds + 8 child references,
//! cache-line aligned), a triangle group 320 bytes (9 coordinates and an id
//! for each of 8 triangles). With the tuned SAH this comes to 51–65 bytes
//! per triangle on the CS184 meshes and procedural meshes (see `PERF.md`).
//!
//! From outside the renderer (a bench, a tool), a triangle soup becomes a
//! [`Geometry`], and a batch of rays is traced with one call per query:
//!
//! ```
//! use glam::Vec3;
//! use wavepath::bvh::{Accel, Bvh, TraversalStats};
//! use wavepath::ray::{Hits, NO_HIT, Rays};
//! use wavepath::scene::{Geometry, Triangles};
//!
//! // Two triangles: a unit square in the z = 0 plane.
//! let positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
//! let indices = vec![[0, 1, 2], [0, 2, 3]];
//! let geometry = Geometry {
//!     triangles: Triangles {
//!         material: vec![0; indices.len()],
//!         positions,
//!         indices,
//!         ..Triangles::default()
//!     },
//!     ..Geometry::default()
//! };
//! let bvh = Bvh::build(&geometry, Accel::Sah);
//!
//! // A batch: one ray down onto each triangle, one beside the square.
//! let mut rays = Rays::with_capacity(3);
//! for (x, y) in [(0.75, 0.25), (0.25, 0.75), (2.0, 2.0)] {
//!     rays.push(Vec3::new(x, y, 1.0), -Vec3::Z, f32::INFINITY);
//! }
//! let (mut hits, mut stats) = (Hits::default(), TraversalStats::default());
//! bvh.intersect(&rays, &mut hits, &mut stats, None);
//! assert_eq!(hits.prim, [0, 1, NO_HIT]);
//! assert_eq!(hits.t[..2], [1.0, 1.0]);
//!
//! // Any hit, e.g. shadow rays: a ray ending before the square is clear.
//! rays.t_max[0] = 0.5;
//! let mut occluded = Vec::new();
//! bvh.occluded(&rays, &mut occluded, &mut stats);
//! assert_eq!(occluded, [false, true, false]);
//! ```
//!
//! [`Accel::None`] skips the hierarchy and tests every primitive; it is the
//! reference the property tests check the others against and the "before"
//! of the before/after comparison.
//!
//! Code generation: all SIMD goes through `wide`, so it is portable and
//! needs no `unsafe`. The project's `.cargo/config.toml` compiles for the
//! host CPU, where an 8-lane register is one AVX register; on the baseline
//! x86-64 target it is two SSE registers (about 15% slower renders,
//! PERF.md).

mod build;
mod bundle;
mod collapse;
mod flatten;
mod packet;
mod sphere;
mod traverse;
mod triangle;

use std::fmt;
use std::ops::AddAssign;
use std::str::FromStr;

use glam::Vec3;

use crate::ray::{Hits, Rays};
use crate::scene::{Aabb, Geometry, Spheres, Triangles};

use build::BuildParams;
use flatten::{ChildRef, WideNode};
use sphere::PackedSphere;
use triangle::TriGroup;

/// How far before a flat box lying across its end a ray must stop, as a
/// multiple of the magnitudes involved, for the traversal to cull that box
/// rather than enter it (a shadow ray ending at a flat emitter).
///
/// A ray `o + t·d`, `t ∈ [0, 1]`, is culled from boxes entered beyond
/// `1 + S + S·(E + |o|∞)/|d|∞` (S = `SLACK_ULPS`, E the scene's largest
/// coordinate magnitude; see `traverse::SLACK_ULPS`). A box in a plane
/// that the ray reaches a distance δ beyond its end (δ measured along the
/// ray, which is at least δ along any axis) is entered at
/// `1 + δ/|d| ≥ 1 + δ/(√3·|d|∞)`. So δ ≥ √3·S·(|d|∞ + E + |o|∞) culls it,
/// and twice S·(reach + E + |o|∞) with reach ≥ |d|∞ covers the √3; the
/// other factor of two is the margin for the rounding of the slab test
/// and of `t` itself.
pub(crate) const END_CLEARANCE: f32 = 4.0 * traverse::SLACK_ULPS;

/// Whether closest-hit packets may span two batch slots (sixteen rays in
/// `wide::f32x16` registers): only where those are one register. On this
/// project's AVX-512 target they cut the packets' per-node control per ray
/// by half (PERF.md); with 8-lane hardware each operation would be two.
const WIDE_PACKETS: bool = cfg!(target_feature = "avx512f");

/// SIMD register type of the node and triangle tests.
pub(crate) type Lanes = wide::f32x8;
/// Children per node: the lane count of `Lanes` (`wide::f32x8`).
pub const WIDTH: usize = 8;
/// SIMD register type of the triangle test. 4 lanes (f32x4) measured the
/// same speed on CBbunny/maxplanck but needs ~30% more nodes and memory.
pub(crate) type TriLanes = wide::f32x8;
/// Triangles per leaf group: the lane count of `TriLanes` (`wide::f32x8`).
pub const TRI_WIDTH: usize = 8;

/// Which acceleration structure to build (`--accel sah|median|none`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Accel {
    /// Binned surface area heuristic: the fast one.
    #[default]
    Sah,
    /// Split at the midpoint of the longest centroid axis, leaves of ≤ 4
    /// (the wide layout may still join a small subtree into one leaf).
    Median,
    /// No hierarchy: every ray tests every primitive.
    None,
}

impl FromStr for Accel {
    type Err = String;

    fn from_str(s: &str) -> Result<Accel, String> {
        match s.to_ascii_lowercase().as_str() {
            "sah" => Ok(Accel::Sah),
            "median" => Ok(Accel::Median),
            "none" => Ok(Accel::None),
            _ => Err(format!(
                "unknown acceleration structure '{s}' (expected sah, median or none)"
            )),
        }
    }
}

impl fmt::Display for Accel {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(match self {
            Accel::Sah => "sah",
            Accel::Median => "median",
            Accel::None => "none",
        })
    }
}

/// Traversal work counters, summed over rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Rays queried.
    pub rays: u64,
    /// Interior (wide) nodes whose child boxes were tested.
    pub nodes_visited: u64,
    /// Primitives tested (padding lanes of triangle groups not counted).
    pub primitives_tested: u64,
}

impl AddAssign for TraversalStats {
    fn add_assign(&mut self, o: TraversalStats) {
        self.rays += o.rays;
        self.nodes_visited += o.nodes_visited;
        self.primitives_tested += o.primitives_tested;
    }
}

/// An acceleration structure over triangles and spheres.
///
/// Owns a copy of the primitive data in the layout traversal wants, so it
/// does not borrow the scene. Queries take `&self` and touch no shared
/// mutable state: one `Bvh` can serve many threads.
pub struct Bvh {
    accel: Accel,
    nodes: Vec<WideNode>,
    tri_groups: Vec<TriGroup>,
    spheres: Vec<PackedSphere>,
    root: Option<ChildRef>,
    /// Bounds of everything (min, max corner), for the batch-level cull.
    bounds: [[f32; 3]; 2],
    depth: usize,
    triangle_count: usize,
    sphere_count: usize,
    /// How the walks treat slivers (`TriGroup::slivers`): see
    /// [`walk_for_slivers`].
    walk: u8,
}

impl Bvh {
    /// Builds an acceleration structure over all primitives of `geometry`.
    /// Hit ids are the global primitive ids of [`Geometry`].
    pub fn build(geometry: &Geometry, accel: Accel) -> Bvh {
        let tri_count = geometry.triangles.len();
        let sphere_count = geometry.spheres.len();
        let mut bvh = Bvh {
            accel,
            nodes: Vec::new(),
            tri_groups: Vec::new(),
            spheres: Vec::new(),
            root: None,
            bounds: [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]],
            depth: 0,
            triangle_count: tri_count,
            sphere_count,
            walk: traverse::PLAIN,
        };
        if accel == Accel::None {
            let ids: Vec<u32> = (0..tri_count as u32).collect();
            bvh.tri_groups = flatten::pack_triangles(&ids, geometry);
            bvh.spheres = (0..sphere_count)
                .map(|i| PackedSphere {
                    center: geometry.spheres.center[i],
                    radius: geometry.spheres.radius[i],
                    id: (tri_count + i) as u32,
                })
                .collect();
            bvh.walk = walk_for_slivers(&bvh.tri_groups);
            return bvh;
        }

        let bounds: Vec<Aabb> = {
            use rayon::prelude::*;
            (0..(tri_count + sphere_count) as u32)
                .into_par_iter()
                .map(|id| geometry.primitive_bounds(id))
                .collect()
        };
        let params = match accel {
            // Tuned on CBbunny and maxplanck (PERF.md): a traversal cost of 2
            // primitive tests per binary node, charged per 8-lane group,
            // fills the triangle groups (64-72 bytes/triangle instead of
            // 110-124 at cost 1, with the greedy collapse of the time) at
            // equal or better speed.
            Accel::Sah => BuildParams {
                sah: true,
                bins: 16,
                traversal_cost: 2.0,
                lanes: TRI_WIDTH,
                max_leaf: 8,
                top_slots: WIDTH,
            },
            _ => BuildParams::MIDPOINT,
        };
        let (root, order) = build::build(&bounds, tri_count as u32, params);
        let flat = flatten::flatten(root.as_ref(), &order, geometry);
        assert!(
            flat.depth * (WIDTH - 1) + WIDTH <= traverse::STACK_SIZE,
            "BVH too deep for the traversal stack"
        );
        // The layout allocates each array at its final size.
        bvh.nodes = flat.nodes;
        bvh.tri_groups = flat.tri_groups;
        bvh.spheres = flat.spheres;
        bvh.root = flat.root;
        bvh.depth = flat.depth;
        bvh.walk = walk_for_slivers(&bvh.tri_groups);
        if let Some(root) = root {
            let b = root.bounds();
            bvh.bounds = [b.min.to_array(), b.max.to_array()];
        }
        bvh
    }

    /// Builds over a bare indexed triangle list (ids are triangle indices).
    pub fn from_triangle_soup(positions: &[Vec3], indices: &[[u32; 3]], accel: Accel) -> Bvh {
        let geometry = Geometry {
            triangles: Triangles {
                positions: positions.to_vec(),
                normals: Vec::new(),
                indices: indices.to_vec(),
                material: vec![0; indices.len()],
                texcoords: Vec::new(),
            },
            spheres: Spheres::default(),
        };
        Bvh::build(&geometry, accel)
    }

    fn scene(&self) -> Option<traverse::Scene<'_>> {
        self.root.map(|root| traverse::Scene {
            nodes: &self.nodes,
            tri_groups: &self.tri_groups,
            spheres: &self.spheres,
            root,
            extent: self
                .bounds
                .iter()
                .flatten()
                .fold(0.0f32, |m, &x| m.max(x.abs())),
        })
    }

    /// Closest hit for every ray of the batch. `hits` is reset to
    /// `rays.len()` misses first; a hit stores `t`, the global primitive id
    /// and, for triangles, the barycentric weights `u`, `v` of vertices 1
    /// and 2.
    ///
    /// `cost`, when given (length ≥ `rays.len()`), receives per ray the
    /// number of nodes visited plus primitives tested.
    ///
    /// A ray hits at `t ∈ [0, t_max]` (both ends included; surfaces
    /// touched exactly at an edge or vertex count). Rays with a zero or
    /// non-finite direction, a non-finite origin, or `t_max` < 0 or NaN
    /// never hit; direction components below f32's normal range count as
    /// zeros. Spheres report the nearest root in range (the far one
    /// when the origin is inside).
    pub fn intersect(
        &self,
        rays: &Rays,
        hits: &mut Hits,
        stats: &mut TraversalStats,
        cost: Option<&mut [u32]>,
    ) {
        match self.walk {
            traverse::PLAIN => self.intersect_walk::<{ traverse::PLAIN }>(rays, hits, stats, cost),
            traverse::FAST => self.intersect_walk::<{ traverse::FAST }>(rays, hits, stats, cost),
            _ => self.intersect_walk::<{ traverse::CAREFUL }>(rays, hits, stats, cost),
        }
    }

    /// [`intersect`](Self::intersect), walking as `WALK` says
    /// (`traverse::PLAIN`, `FAST` or `CAREFUL`).
    #[inline(never)]
    fn intersect_walk<const WALK: u8>(
        &self,
        rays: &Rays,
        hits: &mut Hits,
        stats: &mut TraversalStats,
        cost: Option<&mut [u32]>,
    ) {
        let n = rays.len();
        hits.reset(n);
        let scene = self.scene();
        let src = ray_src(rays);
        let mut batch = ClosestBatch {
            bvh: self,
            rays,
            hits,
            cost,
            stack: traverse::new_stack(),
            packet_stack: packet::new_packet_stack(),
            wide_packet_stack: packet::new_packet_stack(),
            nodes: 0,
            prims: 0,
        };
        // Slot by slot; with wide packets enabled, when a slot and the next
        // both have rays that may hit and all of those point into one
        // octant, the two walk the tree as one sixteen-ray packet. (The
        // next slot's cull is carried over otherwise, so that the slot
        // code below has one call site: inlined twice, it measured ~3%
        // more instructions on incoherent rays.) A slot whose rays all
        // miss the scene's bounds is only counted, and its cull (~250
        // bytes) is never moved: such slots are often a quarter of the
        // camera rays, and the copies cost more than their tests.
        let mut carried = None;
        let mut start = 0;
        while start < n {
            let first = carried
                .take()
                .unwrap_or_else(|| self.cull(&scene, &src, start));
            if first.1 == 0 {
                batch.miss_slot(start);
                start += WIDTH;
                continue;
            }
            let next = start + WIDTH;
            let mut next_misses = false;
            if WIDE_PACKETS
                && next < n
                && let (Some(hierarchy), None, Some(c0)) = (&scene, &batch.cost, &first.0)
            {
                let second = self.cull(&scene, &src, next);
                if second.1 == 0 {
                    next_misses = true;
                } else if let Some(c1) = &second.0
                    && let Some((packet, active)) =
                        packet::Packet::<wide::f32x16>::new(&src, start, &[c0, c1])
                {
                    let mut stack = std::mem::take(&mut batch.wide_packet_stack);
                    batch.trace_packet::<_, WALK>(hierarchy, &mut stack, &packet, active, start);
                    batch.wide_packet_stack = stack;
                    start = next + WIDTH;
                    continue;
                } else {
                    carried = Some(second);
                }
            }
            batch.trace_slot::<WALK>(&scene, &src, start, first);
            start = next;
            if next_misses {
                batch.miss_slot(start);
                start += WIDTH;
            }
        }
        stats.rays += n as u64;
        stats.nodes_visited += batch.nodes;
        stats.primitives_tested += batch.prims;
    }

    /// Whether anything is hit in `[0, t_max]`, for every ray of the batch
    /// (stops at the first hit found). `occluded` is resized to `rays.len()`.
    pub fn occluded(&self, rays: &Rays, occluded: &mut Vec<bool>, stats: &mut TraversalStats) {
        match self.walk {
            traverse::PLAIN => self.occluded_walk::<{ traverse::PLAIN }>(rays, occluded, stats),
            traverse::FAST => self.occluded_walk::<{ traverse::FAST }>(rays, occluded, stats),
            _ => self.occluded_walk::<{ traverse::CAREFUL }>(rays, occluded, stats),
        }
    }

    /// [`occluded`](Self::occluded), walking as `WALK` says.
    #[inline(never)]
    fn occluded_walk<const WALK: u8>(
        &self,
        rays: &Rays,
        occluded: &mut Vec<bool>,
        stats: &mut TraversalStats,
    ) {
        let n = rays.len();
        occluded.clear();
        occluded.resize(n, false);
        let (mut nodes, mut prims) = (0u64, 0u64);
        let scene = self.scene();
        let mut stack = traverse::new_stack();
        let mut bundle_stack = bundle::new_bundle_stack();
        let src = ray_src(rays);
        for start in (0..n).step_by(WIDTH) {
            let (cull, candidates) = self.cull(&scene, &src, start);
            if candidates == 0 {
                nodes += ((start + WIDTH).min(n) - start) as u64;
                continue;
            }
            // Two or more rays walk the tree as a bundle; a lone ray walks
            // it alone (a bundle of one would only add bookkeeping).
            if let (Some(scene), Some(c)) = (&scene, &cull)
                && c.mask.count_ones() >= 2
            {
                let bundle = bundle::Bundle::new(&src, start, c);
                let end = (start + WIDTH).min(n);
                let t_max: [f32; WIDTH] = std::array::from_fn(|lane| {
                    rays.t_max.get(start + lane).copied().unwrap_or(0.0)
                });
                let mut work = [traverse::Work::default(); WIDTH];
                let mut visits = 0;
                let hit = bundle::any::<WALK>(
                    scene,
                    &mut bundle_stack,
                    &bundle,
                    c.mask,
                    &t_max,
                    &mut work,
                    &mut visits,
                );
                for (lane, o) in occluded[start..end].iter_mut().enumerate() {
                    *o = hit & (1 << lane) != 0;
                }
                // Rays that met slivers and nothing else: walked again,
                // carefully (traverse::group_closest).
                for lane in crate::lanes::each(c.mask & !hit) {
                    if WALK != traverse::PLAIN && work[lane].unsure {
                        let i = start + lane;
                        let ray = (rays.origin(i), traverse::flush_subnormal(rays.direction(i)));
                        let ray = (ray.0, ray.1, rays.t_max[i]);
                        occluded[i] = work[lane].walk_again(|w| {
                            traverse::any_careful(scene, &mut stack, (c, lane), ray, w)
                        });
                    }
                }
                nodes += slot_nodes(visits, candidates, end - start);
                if WALK != traverse::PLAIN {
                    // The second walks' node visits (bundles count theirs
                    // in `visits`).
                    nodes += work.iter().map(|w| w.nodes as u64).sum::<u64>();
                }
                prims += work.iter().map(|w| w.prims as u64).sum::<u64>();
                continue;
            }
            #[allow(clippy::needless_range_loop)] // i also indexes the ray arrays
            for i in start..(start + WIDTH).min(n) {
                let mut work = traverse::Work::default();
                if candidates & (1 << (i - start)) == 0 {
                    work.nodes = 1;
                } else {
                    let o = rays.origin(i);
                    let d = traverse::flush_subnormal(rays.direction(i));
                    let t_max = rays.t_max[i];
                    occluded[i] = match (&scene, &cull) {
                        (Some(scene), Some(cull)) => {
                            let ray = (o, d, t_max);
                            let lane = (cull, i - start);
                            traverse::any::<WALK>(scene, &mut stack, lane, ray, &mut work)
                                || WALK != traverse::PLAIN
                                    && work.unsure
                                    && work.walk_again(|w| {
                                        traverse::any_careful(scene, &mut stack, lane, ray, w)
                                    })
                        }
                        _ => work.walk_again(|w| {
                            traverse::any_brute(&self.tri_groups, &self.spheres, (o, d, t_max), w)
                        }),
                    };
                }
                nodes += work.nodes as u64;
                prims += work.prims as u64;
            }
        }
        stats.rays += n as u64;
        stats.nodes_visited += nodes;
        stats.primitives_tested += prims;
    }

    /// The batch cull of rays `start..` (with a hierarchy) and the lanes to
    /// trace: those the cull let through, every lane without a hierarchy
    /// (brute force checks each ray itself), none in an empty scene.
    #[inline(always)]
    fn cull(
        &self,
        scene: &Option<traverse::Scene>,
        src: &traverse::Ray8Src,
        start: usize,
    ) -> (Option<traverse::Cull>, u32) {
        match (scene, self.accel) {
            (_, Accel::None) => (None, u32::MAX),
            (Some(scene), _) => {
                let cull = traverse::may_hit(&self.bounds, scene.extent, src, start);
                let mask = cull.mask;
                (Some(cull), mask)
            }
            (None, _) => (None, 0),
        }
    }

    /// Which structure this is.
    pub fn accel(&self) -> Accel {
        self.accel
    }

    /// Heap bytes owned: nodes plus the primitive copies.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<WideNode>()
            + self.tri_groups.capacity() * std::mem::size_of::<TriGroup>()
            + self.spheres.capacity() * std::mem::size_of::<PackedSphere>()
    }

    /// Number of wide interior nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Wide levels on the longest root-to-leaf path (0 without a hierarchy).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Number of triangles plus spheres.
    pub fn primitive_count(&self) -> usize {
        self.triangle_count + self.sphere_count
    }

    /// Triangle groups of [`WIDTH`] lanes (≥ triangles / WIDTH; padding in
    /// partly filled leaf groups is the difference).
    pub fn triangle_group_count(&self) -> usize {
        self.tri_groups.len()
    }

    /// How the queries treat long thin triangles (slivers, whose hits
    /// may take their distance from the plane in f64): `"plain"` in a
    /// scene without them, `"fast"` with a few (rays that meet one are
    /// walked again), `"careful"` with more than one in a hundred. The
    /// answers are the same; the costs differ.
    pub fn sliver_walk(&self) -> &'static str {
        match self.walk {
            traverse::PLAIN => "plain",
            traverse::FAST => "fast",
            _ => "careful",
        }
    }
}

/// Node visits of the `lanes` rays of one packet (one or two batch slots)
/// or bundle, counted as the single-ray path counts them: the visits
/// summed over its rays, plus one (the scene box) per ray the batch cull
/// rejected; rays that passed the cull but cannot hit anything count none.
fn slot_nodes(visits: u64, candidates: u32, lanes: usize) -> u64 {
    let in_slot = (1u32 << lanes) - 1;
    visits + u64::from((!candidates & in_slot).count_ones())
}

/// How to walk a scene whose triangles are `groups`: [`traverse::PLAIN`]
/// without slivers; with a few, [`traverse::FAST`] (rays that meet one
/// are walked twice); with more than one triangle in a hundred,
/// [`traverse::CAREFUL`] from the start. On building (9% slivers) fast
/// walks walked so many rays twice that careful ones were faster
/// (PERF.md, BVH, session of 2026-11-28).
fn walk_for_slivers(groups: &[TriGroup]) -> u8 {
    let (mut slivers, mut triangles) = (0, 0);
    for g in groups {
        slivers += g.slivers().count_ones();
        triangles += g.len();
    }
    if slivers == 0 {
        traverse::PLAIN
    } else if slivers * 100 <= triangles {
        traverse::FAST
    } else {
        traverse::CAREFUL
    }
}

/// The state of one [`Bvh::intersect`] call: where results and counters
/// go, and the traversal stacks reused across the batch.
struct ClosestBatch<'a> {
    bvh: &'a Bvh,
    rays: &'a Rays,
    hits: &'a mut Hits,
    cost: Option<&'a mut [u32]>,
    stack: traverse::Stack,
    packet_stack: packet::PacketStack<Lanes>,
    wide_packet_stack: packet::PacketStack<wide::f32x16>,
    nodes: u64,
    prims: u64,
}

impl ClosestBatch<'_> {
    /// Counts the batch slot at `start` whose rays all miss the scene's
    /// bounds (a quarter or more of the camera rays in a typical view):
    /// one node visit each, the box test they did get; nothing is traced.
    #[inline(never)]
    fn miss_slot(&mut self, start: usize) {
        let end = (start + WIDTH).min(self.rays.len());
        self.nodes += (end - start) as u64;
        if let Some(cost) = self.cost.as_deref_mut() {
            cost[start..end].fill(1);
        }
    }

    /// Traces the rays of the batch slot at `start`, given the slot's
    /// batch cull (with a hierarchy) and lanes to trace (at least one; see
    /// [`miss_slot`](Self::miss_slot)): as a packet when that pays (no
    /// per-ray costs asked for, two or more rays, one octant), else ray
    /// by ray.
    #[inline(always)]
    fn trace_slot<const WALK: u8>(
        &mut self,
        scene: &Option<traverse::Scene>,
        src: &traverse::Ray8Src,
        start: usize,
        (cull, candidates): (Option<traverse::Cull>, u32),
    ) {
        debug_assert!(candidates != 0);
        let (rays, n) = (self.rays, self.rays.len());
        let end = (start + WIDTH).min(n);
        if let (Some(scene), None, Some(c)) = (scene, &self.cost, &cull)
            && c.mask.count_ones() >= 2
            && let Some((packet, active)) = packet::Packet::<Lanes>::new(src, start, &[c])
        {
            let mut stack = std::mem::take(&mut self.packet_stack);
            self.trace_packet::<_, WALK>(scene, &mut stack, &packet, active, start);
            self.packet_stack = stack;
            return;
        }
        // Locals, not fields: the loop then keeps them in registers.
        let (stack, hits) = (&mut self.stack, &mut *self.hits);
        let (mut nodes, mut prims) = (0, 0);
        for i in start..end {
            let mut work = traverse::Work::default();
            if candidates & (1 << (i - start)) == 0 {
                work.nodes = 1;
            } else {
                let d = traverse::flush_subnormal(rays.direction(i));
                let (o, t_max) = (rays.origin(i), rays.t_max[i]);
                let c = match (scene, &cull) {
                    (Some(scene), Some(cull)) => {
                        let (lane, ray) = ((cull, i - start), (o, d, t_max));
                        let fast = traverse::closest::<WALK>(scene, stack, lane, ray, &mut work);
                        if WALK != traverse::PLAIN && work.unsure {
                            // It met slivers (traverse::group_closest).
                            work.walk_again(|w| {
                                traverse::closest_careful(scene, stack, lane, ray, w)
                            })
                        } else {
                            fast
                        }
                    }
                    _ => work.walk_again(|w| {
                        let (groups, spheres) = (&self.bvh.tri_groups, &self.bvh.spheres);
                        traverse::closest_brute(groups, spheres, (o, d, t_max), w)
                    }),
                };
                hits.record(i, &c);
            }
            if let Some(cost) = self.cost.as_deref_mut() {
                cost[i] = work.nodes + work.prims;
            }
            nodes += work.nodes as u64;
            prims += work.prims as u64;
        }
        self.nodes += nodes;
        self.prims += prims;
    }

    /// Traces `packet`: the rays `active` of the `L::SLOTS` batch slots
    /// from `start`, which are the rays their culls let through.
    #[inline(always)]
    fn trace_packet<L: packet::RayLanes, const WALK: u8>(
        &mut self,
        scene: &traverse::Scene,
        stack: &mut packet::PacketStack<L>,
        packet: &packet::Packet<L>,
        active: u32,
        start: usize,
    ) {
        let end = (start + L::SLOTS * WIDTH).min(self.rays.len());
        let t_max = &self.rays.t_max[start..end];
        let mut best = traverse::ClosestLanes::none(t_max);
        let mut work = traverse::Work::default();
        let mut visits = 0;
        packet::closest::<L, WALK>(
            scene,
            stack,
            packet,
            active,
            &mut best,
            &mut work,
            &mut visits,
        );
        if WALK != traverse::PLAIN && work.unsure {
            // It met slivers (traverse::group_closest): walked again.
            best = traverse::ClosestLanes::none(t_max);
            work.walk_again(|w| {
                packet::closest_careful(scene, stack, packet, active, &mut best, w, &mut visits)
            });
        }
        self.hits.record_lanes(start..end, &best);
        self.nodes += slot_nodes(visits, active, end - start);
        self.prims += u64::from(work.prims);
    }
}

impl Hits {
    /// Stores ray `i`'s closest hit, if any.
    #[inline(always)]
    fn record(&mut self, i: usize, c: &traverse::Closest) {
        if c.prim != crate::ray::NO_HIT {
            self.t[i] = c.t;
            self.prim[i] = c.prim;
            self.u[i] = c.u;
            self.v[i] = c.v;
        }
    }

    /// Stores the closest hits of rays `range` (lanes `0..` of `best`),
    /// misses stored as [`reset`](Hits::reset) stores them, without a
    /// branch per ray.
    #[inline(always)]
    fn record_lanes(&mut self, range: std::ops::Range<usize>, best: &traverse::ClosestLanes) {
        let n = range.len();
        let (t, prim) = (&mut self.t[range.clone()], &mut self.prim[range.clone()]);
        let (u, v) = (&mut self.u[range.clone()], &mut self.v[range]);
        for i in 0..n {
            let hit = best.prim[i] != crate::ray::NO_HIT;
            t[i] = if hit { best.t[i] } else { f32::INFINITY };
            prim[i] = best.prim[i];
            u[i] = if hit { best.u[i] } else { 0.0 };
            v[i] = if hit { best.v[i] } else { 0.0 };
        }
    }
}

fn ray_src(rays: &Rays) -> traverse::Ray8Src<'_> {
    traverse::Ray8Src {
        org: [&rays.org_x, &rays.org_y, &rays.org_z],
        dir: [&rays.dir_x, &rays.dir_y, &rays.dir_z],
        t_max: &rays.t_max,
    }
}

// Queries share nothing mutable; this fails to compile if that changes.
const _: () = {
    const fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Bvh>();
};

#[cfg(test)]
mod tests {
    use super::*;

    /// The flat pieces the build sets apart end up as children of the
    /// root wide node, one slot each, even when the rest of the scene has
    /// the biggest box (collapsing by area alone would open the rest first
    /// and leave two pieces sharing a slot).
    #[test]
    fn flat_pieces_are_root_slots() {
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        let mut quad = |a: Vec3, b: Vec3, c: Vec3| {
            let i = positions.len() as u32;
            positions.extend([a, b, c, a + c - b]);
            indices.extend([[i, i + 1, i + 2], [i, i + 2, i + 3]]);
        };
        // A floor and two walls, then a scattered mesh reaching past them.
        let (x0, x1, y0, y1, z0, z1) = (-1.0, 1.0, 0.0, 1.5, -1.0, 1.0);
        quad(
            Vec3::new(x0, y0, z0),
            Vec3::new(x1, y0, z0),
            Vec3::new(x1, y0, z1),
        );
        quad(
            Vec3::new(x0, y0, z0),
            Vec3::new(x0, y1, z0),
            Vec3::new(x0, y1, z1),
        );
        quad(
            Vec3::new(x0, y0, z0),
            Vec3::new(x1, y0, z0),
            Vec3::new(x1, y1, z0),
        );
        for k in 0..400 {
            let (i, j) = ((k % 20) as f32, (k / 20) as f32);
            let o = Vec3::new(i * 0.4 - 4.0, 0.2 + 0.05 * (i % 3.0), j * 0.4 - 4.0);
            quad(o, o + Vec3::X * 0.02, o + Vec3::new(0.02, 0.02, 0.01));
        }
        let bvh = Bvh::from_triangle_soup(&positions, &indices, Accel::Sah);
        let root = &bvh.nodes[bvh.root.unwrap().index()];
        let mut walls = Vec::new();
        for slot in 0..WIDTH {
            let child = root.child[slot];
            if !child.is_leaf() || root.bounds[0][0].as_array()[slot].is_infinite() {
                continue;
            }
            let mut ids: Vec<u32> = bvh.tri_groups[child.index()..child.index() + child.count()]
                .iter()
                .flat_map(TriGroup::prims)
                .collect();
            ids.sort();
            walls.push(ids);
        }
        walls.sort();
        let expected: Vec<Vec<u32>> = (0..3).map(|w| vec![2 * w, 2 * w + 1]).collect();
        assert_eq!(walls, expected);
    }
}
