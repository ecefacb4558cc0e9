//! Property tests: every acceleration structure answers exactly like brute force.
//!
//! `Accel::None` tests every primitive, so it is the reference. For a
//! closest-hit query the structures must report the same primitive at the
//! same `t`, bit for bit: every path runs the same per-primitive
//! arithmetic, and exact ties (a ray through a shared edge or vertex) go
//! to the lower primitive id whatever order the primitives are met in.

use std::path::Path;

use glam::Vec3;
use proptest::prelude::*;
use wavepath::bvh::{Accel, Bvh, TraversalStats};
use wavepath::ray::{Hits, NO_HIT, Rays, offset_from_surface, surface_reach};
use wavepath::scene::{Geometry, Spheres, Triangles};

const ACCELS: [Accel; 2] = [Accel::Sah, Accel::Median];

fn geometry(positions: Vec<Vec3>, indices: Vec<[u32; 3]>, spheres: Vec<(Vec3, f32)>) -> Geometry {
    let n = indices.len();
    Geometry {
        triangles: Triangles {
            positions,
            normals: Vec::new(),
            indices,
            material: vec![0; n],
            texcoords: Vec::new(),
        },
        spheres: Spheres {
            center: spheres.iter().map(|s| s.0).collect(),
            radius: spheres.iter().map(|s| s.1).collect(),
            material: vec![0; spheres.len()],
        },
    }
}

/// Separate triangles, each a corner and two edge vectors, plus spheres.
fn soup(tris: Vec<(Vec3, Vec3, Vec3)>, spheres: Vec<(Vec3, f32)>) -> Geometry {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for (a, e1, e2) in tris {
        let k = positions.len() as u32;
        positions.extend([a, a + e1, a + e2]);
        indices.push([k, k + 1, k + 2]);
    }
    geometry(positions, indices, spheres)
}

/// Checks `accel` against brute force on `rays`; returns a description of
/// the first disagreement.
fn compare(geometry: &Geometry, rays: &Rays) -> Result<usize, String> {
    let hits = compare_once(geometry, rays)?;
    // Again with every hitting ray ending exactly at its hit: the hit must
    // survive (t ∈ [0, t_max] is closed) in the hierarchies too, which
    // stresses the rounding margins of the box tests.
    let reference = Bvh::build(geometry, Accel::None);
    let mut expected = Hits::default();
    reference.intersect(rays, &mut expected, &mut TraversalStats::default(), None);
    let mut ending = rays.clone();
    for i in 0..rays.len() {
        if expected.is_hit(i) {
            ending.t_max[i] = expected.t[i];
        }
    }
    let again = compare_once(geometry, &ending)?;
    if again != hits {
        return Err(format!(
            "{again} hits with t_max = hit distance, {hits} before"
        ));
    }
    Ok(hits)
}

fn compare_once(geometry: &Geometry, rays: &Rays) -> Result<usize, String> {
    let reference = Bvh::build(geometry, Accel::None);
    let mut expected = Hits::default();
    let mut stats = TraversalStats::default();
    reference.intersect(rays, &mut expected, &mut stats, None);
    let mut expected_occ = Vec::new();
    reference.occluded(rays, &mut expected_occ, &mut stats);
    for accel in ACCELS {
        let bvh = Bvh::build(geometry, accel);
        let mut hits = Hits::default();
        let mut cost = vec![0u32; rays.len()];
        bvh.intersect(rays, &mut hits, &mut stats, Some(&mut cost));
        // Without per-ray costs, rays of one octant go through packet
        // traversal: the answers must be bit-identical to single rays'.
        let mut packet_hits = Hits::default();
        bvh.intersect(rays, &mut packet_hits, &mut stats, None);
        for i in 0..rays.len() {
            let single = (
                hits.prim[i],
                hits.t[i].to_bits(),
                hits.u[i].to_bits(),
                hits.v[i].to_bits(),
            );
            let packet = (
                packet_hits.prim[i],
                packet_hits.t[i].to_bits(),
                packet_hits.u[i].to_bits(),
                packet_hits.v[i].to_bits(),
            );
            if single != packet {
                return Err(format!(
                    "{accel}: ray {i} ({:?} + t {:?}): single-ray hit {single:?}, packet hit {packet:?}",
                    rays.origin(i),
                    rays.direction(i)
                ));
            }
        }
        let mut occ = Vec::new();
        bvh.occluded(rays, &mut occ, &mut stats);
        for i in 0..rays.len() {
            let (ep, gp) = (expected.prim[i], hits.prim[i]);
            let ok = ep == gp && (ep == NO_HIT || expected.t[i].to_bits() == hits.t[i].to_bits());
            if !ok {
                return Err(format!(
                    "{accel}: ray {i} ({:?} + t {:?}, t_max {}): expected prim {ep} t {}, got prim {gp} t {}",
                    rays.origin(i),
                    rays.direction(i),
                    rays.t_max[i],
                    expected.t[i],
                    hits.t[i]
                ));
            }
            if ep != NO_HIT
                && ep == gp
                && (expected.u[i] != hits.u[i] || expected.v[i] != hits.v[i])
            {
                let du = (expected.u[i] - hits.u[i]).abs() + (expected.v[i] - hits.v[i]).abs();
                if du > 1e-4 {
                    return Err(format!("{accel}: ray {i}: barycentrics differ"));
                }
            }
            if occ[i] != expected_occ[i] {
                return Err(format!(
                    "{accel}: ray {i}: occluded {} expected {}",
                    occ[i], expected_occ[i]
                ));
            }
            if occ[i] != (ep != NO_HIT) {
                return Err(format!(
                    "{accel}: ray {i}: occluded disagrees with intersect"
                ));
            }
        }
    }
    Ok(expected.prim.iter().filter(|&&p| p != NO_HIT).count())
}

fn vec3(range: std::ops::Range<f32>) -> impl Strategy<Value = Vec3> {
    (range.clone(), range.clone(), range).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn rays_strategy(n: usize, extent: f32) -> impl Strategy<Value = Rays> {
    proptest::collection::vec(
        (
            vec3(-extent..extent),
            vec3(-1.0..1.0),
            prop_oneof![Just(f32::INFINITY), 0.0f32..3.0 * extent],
        ),
        n,
    )
    .prop_map(|v| {
        let mut rays = Rays::with_capacity(v.len());
        for (o, d, t) in v {
            rays.push(o, d, t);
        }
        rays
    })
}

/// Groups of `per_cone` rays from one origin in a narrow cone, as the
/// samples of a pixel or the shadow rays of one path vertex are: most
/// groups lie in one octant and are traced as packets (closest hit; with
/// 16 per cone, two batch slots at a time where the target has 16-lane
/// registers); any-hit queries trace every slot of two or more rays as a
/// bundle.
fn coherent_rays_strategy(
    groups: usize,
    per_cone: usize,
    extent: f32,
) -> impl Strategy<Value = Rays> {
    proptest::collection::vec(
        (
            vec3(-extent..extent),
            vec3(-1.0..1.0),
            proptest::collection::vec(
                (
                    vec3(-0.1..0.1),
                    prop_oneof![Just(f32::INFINITY), 0.0f32..3.0 * extent],
                ),
                per_cone,
            ),
        ),
        groups,
    )
    .prop_map(|v| {
        let mut rays = Rays::with_capacity(8 * v.len());
        for (o, d, spread) in v {
            for (e, t) in spread {
                rays.push(o, d + e, t);
            }
        }
        rays
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn coherent_bundles(
        tris in proptest::collection::vec((vec3(-1.0..1.0), vec3(-0.3..0.3), vec3(-0.3..0.3)), 1..400),
        spheres in proptest::collection::vec((vec3(-1.0..1.0), 0.01f32..0.4), 0..8),
        rays in coherent_rays_strategy(48, 8, 1.5),
    ) {
        let g = soup(tris, spheres);
        compare(&g, &rays).map_err(TestCaseError::fail)?;
    }

    /// Sixteen-ray cones, and a batch that ends part-way through the
    /// second slot of a pair (13 rays of the last cone).
    #[test]
    fn coherent_wide_packets(
        tris in proptest::collection::vec((vec3(-1.0..1.0), vec3(-0.3..0.3), vec3(-0.3..0.3)), 1..400),
        rays in coherent_rays_strategy(12, 16, 1.5),
    ) {
        let mut rays = rays;
        rays.truncate(rays.len() - 3);
        let g = soup(tris, Vec::new());
        compare(&g, &rays).map_err(TestCaseError::fail)?;
    }

    /// A room (floor, ceiling, four walls: the large flat pieces the SAH
    /// build gives root slots of their own) around a random soup, with
    /// rays from inside and outside it, coherent and not. (The walls are
    /// "large" for `build::LARGE_AREA` = 2%; the unit tests in `build.rs`
    /// check that they are set apart.)
    #[test]
    fn room_around_a_soup(
        tris in proptest::collection::vec((vec3(-0.5..0.5), vec3(-0.1..0.1), vec3(-0.1..0.1)), 1..200),
        rays in rays_strategy(256, 1.2),
        coherent in coherent_rays_strategy(16, 8, 1.2),
    ) {
        let mut all = tris;
        let corners = |x: [f32; 2], y: [f32; 2], z: [f32; 2], along_x: bool| {
            // Two triangles covering an axis-aligned rectangle.
            let a = Vec3::new(x[0], y[0], z[0]);
            let c = Vec3::new(x[1], y[1], z[1]);
            let b = if along_x { Vec3::new(x[1], y[0], z[0]) } else { Vec3::new(x[0], y[1], z[0]) };
            let d = a + c - b;
            [(a, b - a, c - a), (a, c - a, d - a)]
        };
        all.extend(corners([-1.0, 1.0], [-1.0, -1.0], [-1.0, 1.0], true));
        all.extend(corners([-1.0, 1.0], [1.0, 1.0], [-1.0, 1.0], true));
        all.extend(corners([-1.0, -1.0], [-1.0, 1.0], [-1.0, 1.0], false));
        all.extend(corners([1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0], false));
        all.extend(corners([-1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], true));
        all.extend(corners([-1.0, 1.0], [-1.0, 1.0], [1.0, 1.0], true));
        let g = soup(all, Vec::new());
        compare(&g, &rays).map_err(TestCaseError::fail)?;
        compare(&g, &coherent).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn random_soup(
        tris in proptest::collection::vec((vec3(-1.0..1.0), vec3(-0.3..0.3), vec3(-0.3..0.3)), 1..400),
        rays in rays_strategy(256, 1.5),
    ) {
        let g = soup(tris, Vec::new());
        compare(&g, &rays).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn random_spheres_and_triangles(
        spheres in proptest::collection::vec((vec3(-1.0..1.0), 0.01f32..0.4), 1..60),
        tris in proptest::collection::vec((vec3(-1.0..1.0), vec3(-0.3..0.3), vec3(-0.3..0.3)), 0..60),
        rays in rays_strategy(256, 1.5),
    ) {
        let g = soup(tris, spheres);
        compare(&g, &rays).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn grid_mesh_with_shared_edges(
        n in 2usize..40,
        rays in rays_strategy(512, 1.5),
    ) {
        // A bumpy height field: many shared edges and vertices.
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
                positions.push(Vec3::new(x, 0.2 * (3.0 * x).sin() * (2.0 * z).cos(), z));
            }
        }
        let mut indices = Vec::new();
        let idx = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        for j in 0..n {
            for i in 0..n {
                indices.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
                indices.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
            }
        }
        let g = geometry(positions, indices, Vec::new());
        let hits = compare(&g, &rays).map_err(TestCaseError::fail)?;
        prop_assert!(hits > 0);
    }
}

#[test]
fn degenerate_inputs() {
    // Empty scene, zero directions, many identical triangles.
    let empty = geometry(Vec::new(), Vec::new(), Vec::new());
    let mut rays = Rays::default();
    rays.push(Vec3::ZERO, Vec3::X, f32::INFINITY);
    rays.push(Vec3::ZERO, Vec3::ZERO, f32::INFINITY);
    compare(&empty, &rays).unwrap();

    let positions = vec![
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let g = geometry(positions, vec![[0, 1, 2]; 1000], Vec::new());
    rays.push(Vec3::ZERO, Vec3::Z, f32::INFINITY);
    rays.push(Vec3::ZERO, Vec3::Z, 0.5);
    rays.push(Vec3::ZERO, Vec3::Z, 1.0);
    // A ray of length zero starting on the triangle, and one whose
    // direction is the smallest normal float (still a direction).
    rays.push(Vec3::Z, Vec3::Z, 0.0);
    rays.push(
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, f32::MIN_POSITIVE),
        f32::INFINITY,
    );
    compare(&g, &rays).unwrap();
    for accel in [Accel::Sah, Accel::Median, Accel::None] {
        let bvh = Bvh::build(&g, accel);
        let mut hits = Hits::default();
        bvh.intersect(&rays, &mut hits, &mut TraversalStats::default(), None);
        assert_eq!(hits.prim[1], NO_HIT, "zero direction never hits");
        assert!(hits.is_hit(2) && hits.t[2] == 1.0);
        assert!(!hits.is_hit(3));
        assert!(hits.is_hit(4), "t == t_max counts as a hit");
        assert_eq!(hits.prim[2], 0, "exact ties go to the lowest id");
        assert!(hits.is_hit(5) && hits.t[5] == 0.0, "t == 0 == t_max counts");
        // Traced like any other direction (its distance, 2^126, overflows
        // in the triangle test's scaling; brute force agrees, above).
        assert!(
            hits.is_hit(6),
            "the smallest normal direction is a direction"
        );
        assert!((hits.u[2] - 0.25).abs() < 1e-6 && (hits.v[2] - 0.5).abs() < 1e-6);
    }
}

/// Identical spheres tie exactly, wherever the tree puts them: the lower
/// id wins, for single rays and for packets alike.
#[test]
fn sphere_ties_go_to_the_lower_id() {
    let spheres = vec![(Vec3::new(0.0, 0.0, 3.0), 1.0); 5];
    let g = geometry(Vec::new(), Vec::new(), spheres);
    let mut rays = Rays::default();
    for i in 0..16 {
        let o = Vec3::new(0.01 * i as f32, 0.0, 0.0);
        rays.push(o, Vec3::new(0.0, 0.02 * (i % 4) as f32, 1.0), f32::INFINITY);
    }
    for accel in [Accel::Sah, Accel::Median, Accel::None] {
        let bvh = Bvh::build(&g, accel);
        let mut hits = Hits::default();
        bvh.intersect(&rays, &mut hits, &mut TraversalStats::default(), None);
        for i in 0..rays.len() {
            assert_eq!(hits.prim[i], 0, "{accel}: ray {i}");
        }
    }
}

/// Rays that cannot hit anything — non-finite origin or direction, zero
/// or subnormal direction, NaN or negative `t_max` — report no hit and no occlusion in
/// every mode, alone or next to valid rays in the same batch slot (which
/// then may go through packet or bundle traversal).
#[test]
fn invalid_rays_never_hit() {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let g = geometry(positions, vec![[0, 1, 2]; 20], Vec::new());
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let invalid = [
        (Vec3::new(nan, 0.0, 0.0), Vec3::Z, inf),
        (Vec3::new(0.0, inf, 0.0), Vec3::Z, inf),
        (Vec3::ZERO, Vec3::new(0.0, 0.0, inf), inf),
        (Vec3::ZERO, Vec3::new(nan, 0.0, 1.0), inf),
        (Vec3::ZERO, Vec3::new(-0.0, 0.0, -0.0), inf),
        // Subnormal in every component: 1/d overflows.
        (Vec3::ZERO, Vec3::new(1e-40, 0.0, 1e-39), inf),
        (Vec3::ZERO, Vec3::Z, nan),
        (Vec3::ZERO, Vec3::Z, -1.0),
    ];
    let mut rays = Rays::default();
    for (k, &(o, d, t)) in invalid.iter().enumerate() {
        // Valid rays around each invalid one, so slots mix both kinds.
        rays.push(Vec3::new(0.01 * k as f32, 0.0, 0.0), Vec3::Z, inf);
        rays.push(o, d, t);
        rays.push(Vec3::new(0.0, 0.01 * k as f32, 0.0), Vec3::Z, inf);
    }
    for accel in [Accel::Sah, Accel::Median, Accel::None] {
        let bvh = Bvh::build(&g, accel);
        let mut hits = Hits::default();
        let mut occluded = Vec::new();
        let mut stats = TraversalStats::default();
        bvh.intersect(&rays, &mut hits, &mut stats, None);
        bvh.occluded(&rays, &mut occluded, &mut stats);
        for (i, &occluded) in occluded.iter().enumerate() {
            let valid = i % 3 != 1;
            assert_eq!(hits.is_hit(i), valid, "{accel:?} ray {i}: hit");
            assert_eq!(occluded, valid, "{accel:?} ray {i}: occluded");
        }
    }
}

/// Axis-parallel rays travelling exactly in the plane of a box face: the
/// slab test must count the face as inside (as brute force does), for
/// both signs of zero.
#[test]
fn rays_in_box_face_planes() {
    // Two triangles at x = 1 meeting along the line y = 0, one above and
    // one below; plus a grid of quads so that leaf boxes have faces at y = 0
    // and z = 0.
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for (y0, y1) in [(-1.0, 0.0), (0.0, 1.0)] {
        for (z0, z1) in [(-1.0, 0.0), (0.0, 1.0)] {
            let k = positions.len() as u32;
            positions.extend([
                Vec3::new(1.0, y0, z0),
                Vec3::new(1.0, y1, z0),
                Vec3::new(1.0, y1, z1),
                Vec3::new(1.0, y0, z1),
            ]);
            indices.push([k, k + 1, k + 2]);
            indices.push([k, k + 2, k + 3]);
        }
    }
    // Only the lower half: the ray along y = 0 touches its top edge only.
    let lower: Vec<[u32; 3]> = indices[..2].to_vec();
    for idx in [indices, lower] {
        let g = geometry(positions.clone(), idx, Vec::new());
        let mut rays = Rays::default();
        for dy in [0.0f32, -0.0] {
            for dz in [0.0f32, -0.0] {
                rays.push(Vec3::ZERO, Vec3::new(1.0, dy, dz), f32::INFINITY);
                rays.push(
                    Vec3::new(0.0, 0.0, -0.5),
                    Vec3::new(1.0, dy, dz),
                    f32::INFINITY,
                );
                rays.push(Vec3::new(0.0, -0.5, 0.0), Vec3::new(2.0, dy, dz), 10.0);
            }
        }
        let hits = compare(&g, &rays).unwrap();
        assert!(hits > 0);
    }
}

/// A soup 1e5 units from the origin, rays from within it: their hits are
/// a few units away, while the rounding of box and triangle distances
/// there is a few ulps of 1e5. Ending each ray exactly at its hit (as
/// `compare` does) checks that the cull's slack, which grows with the
/// coordinates and not with `t`, keeps the hit's box.
#[test]
fn soup_far_from_the_origin() {
    let mut rng = Rng(0x5eed_f00d);
    for offset in [Vec3::splat(1.0e5), Vec3::new(-3.0e5, 2.0e4, 1.0e5)] {
        let tris = random_tris(&mut rng, 500, offset, 8.0, 2.0);
        let g = soup(tris, vec![(offset, 0.7)]);
        let mut rays = Rays::default();
        for i in 0..2000 {
            let o = offset + (rng.vec3() - Vec3::splat(0.5)) * 10.0;
            let d = rng.vec3() - Vec3::splat(0.5);
            // Also slots of eight rays from one point (packets, bundles).
            let o = if i % 16 < 8 || i % 8 == 0 {
                o
            } else {
                rays.origin(i - i % 8)
            };
            rays.push(o, d, f32::INFINITY);
        }
        let hits = compare(&g, &rays).unwrap_or_else(|e| panic!("offset {offset}: {e}"));
        assert!(hits > 500, "offset {offset}: {hits} hits");
    }
}

/// A floor 2e5 units across, rays starting just above it at grazing
/// angles: the triangle test's distance comes from vertex coordinates of
/// ~1e5, so its rounding is ~1e5·ε, far more than a few ulps of the
/// distance (~1) itself, while the box's entry distance is exact. Ending
/// each ray at its hit checks that the cull's absolute slack, which grows
/// with the coordinates, keeps the floor's box.
#[test]
fn grazing_rays_over_a_huge_floor() {
    let mut rng = Rng(0x0f10_0a5e);
    let h = 1.0e5;
    let floor = [
        (
            Vec3::new(-h, 0.0, -h),
            Vec3::new(2.0 * h, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0 * h),
        ),
        (
            Vec3::new(h, 0.0, h),
            Vec3::new(-2.0 * h, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -2.0 * h),
        ),
    ];
    let g = soup(floor.to_vec(), Vec::new());
    let mut rays = Rays::default();
    for _ in 0..4000 {
        let o = Vec3::new(
            rng.next() * 200.0 - 100.0,
            0.001 + rng.next() * 0.1,
            rng.next() * 200.0 - 100.0,
        );
        let along = rng.vec3() * 2.0 - Vec3::ONE;
        rays.push(
            o,
            Vec3::new(along.x, -0.001 - 0.05 * rng.next(), along.z),
            f32::INFINITY,
        );
    }
    let hits = compare(&g, &rays).unwrap();
    assert!(hits > 3000, "{hits} hits");
}

/// A mesh large enough for the parallel build and flatten paths (which
/// start above ~32k primitives), against brute force.
#[test]
fn large_mesh_parallel_build() {
    let n = 230; // 2·230² ≈ 106k triangles
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                i as f32 / n as f32 * 2.0 - 1.0,
                j as f32 / n as f32 * 2.0 - 1.0,
            );
            positions.push(Vec3::new(x, 0.3 * (5.0 * x).sin() * (4.0 * z).cos(), z));
        }
    }
    let idx = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            indices.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            indices.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    let spheres = vec![
        (Vec3::new(0.2, 0.5, 0.1), 0.2),
        (Vec3::new(-0.5, -0.4, 0.3), 0.3),
    ];
    let g = geometry(positions, indices, spheres);
    let mut rng = Rng(12345);
    let mut rays = Rays::default();
    for _ in 0..300 {
        let o = (rng.vec3() * 2.0 - Vec3::ONE) * 1.2;
        let d = rng.vec3() * 2.0 - Vec3::ONE;
        rays.push(o, d, f32::INFINITY);
    }
    assert!(compare(&g, &rays).unwrap() > 50);
}

#[test]
fn accel_names_round_trip() {
    for a in [Accel::Sah, Accel::Median, Accel::None] {
        assert_eq!(a.to_string().parse::<Accel>(), Ok(a));
    }
    assert!("bogus".parse::<Accel>().is_err());
}

#[test]
fn stats_and_cost_add_up() {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let g = geometry(
        positions,
        vec![[0, 1, 2]; 100],
        vec![(Vec3::new(0.0, 0.0, 5.0), 1.0)],
    );
    let mut rays = Rays::default();
    for i in 0..37 {
        rays.push(
            Vec3::ZERO,
            Vec3::new(i as f32 * 0.05 - 0.9, 0.1, 1.0),
            f32::INFINITY,
        );
    }
    for accel in [Accel::Sah, Accel::Median, Accel::None] {
        let bvh = Bvh::build(&g, accel);
        let mut hits = Hits::default();
        let mut stats = TraversalStats::default();
        let mut cost = vec![0u32; rays.len()];
        bvh.intersect(&rays, &mut hits, &mut stats, Some(&mut cost));
        assert_eq!(stats.rays, rays.len() as u64);
        let total: u64 = cost.iter().map(|&c| c as u64).sum();
        assert_eq!(
            total,
            stats.nodes_visited + stats.primitives_tested,
            "{accel}"
        );
        assert!(
            cost.iter().all(|&c| c > 0),
            "{accel}: every ray costs something"
        );
        let mut occ = Vec::new();
        let mut any_hit = TraversalStats::default();
        bvh.occluded(&rays, &mut occ, &mut any_hit);
        let closest = stats;
        bvh.occluded(&rays, &mut occ, &mut stats);
        assert_eq!(stats.rays, 2 * rays.len() as u64);
        // Counters of two queries add up field by field, either way.
        let mut sum = closest;
        sum += any_hit;
        assert_eq!(sum, stats, "{accel}");
        assert!(any_hit.rays == rays.len() as u64 && any_hit.primitives_tested > 0);
        assert!(bvh.memory_bytes() > 0 && bvh.primitive_count() == 101);
    }
}

/// The work counters count each ray's own work, whichever path traced
/// it. Where the order of the walk cannot matter, the paths must agree
/// exactly: when a slot's rays are identical (a bundle stops them
/// together), or when nothing is hit (each ray visits every node its own
/// box tests enter, and tests every primitive there, in any order) — then
/// a shadow ray bundled, alone, and its closest-hit twin alone or in a
/// packet all report the same counts. A closest-hit packet of identical
/// rays counts each node and primitive once per ray.
#[test]
fn every_path_counts_each_rays_own_work() {
    let mut rng = Rng(0x1234_5678);
    let tris = random_tris(&mut rng, 300, Vec3::ZERO, 2.0, 0.5);
    let spheres = vec![
        (Vec3::new(0.3, -0.2, 0.1), 0.15),
        (Vec3::new(-0.5, 0.4, 0.6), 0.1),
    ];
    let g = soup(tris, spheres);
    let bvhs = ACCELS.map(|accel| Bvh::build(&g, accel));
    let counts = |s: &TraversalStats| (s.nodes_visited, s.primitives_tested);
    let (mut stopped_together, mut unhit, mut unhit_packets) = (0, 0, 0);
    for slot in 0..192 {
        let o = rng.vec3() * 2.4 - Vec3::splat(1.2);
        // Towards the soup's middle, where most rays find an occluder.
        let d = rng.vec3() - Vec3::splat(0.5) - o;
        let kind = slot % 3;
        let mut rays = Rays::default();
        for _ in 0..8 {
            match kind {
                0 => rays.push(o, d, f32::INFINITY),
                // Short rays in all directions, or in a cone (one octant:
                // a closest-hit packet).
                1 => rays.push(o, rng.vec3() * 2.0 - Vec3::ONE, 0.05 + 0.4 * rng.next()),
                _ => rays.push(o, d + rng.vec3() * 0.1, 0.05 + 0.4 * rng.next()),
            }
        }
        for bvh in &bvhs {
            let accel = bvh.accel();
            let mut bundled = TraversalStats::default();
            let mut occluded = Vec::new();
            bvh.occluded(&rays, &mut occluded, &mut bundled);
            let mut alone = TraversalStats::default();
            let mut one = Vec::new();
            for (i, &occluded) in occluded.iter().enumerate() {
                let mut ray = Rays::default();
                ray.push(rays.origin(i), rays.direction(i), rays.t_max[i]);
                bvh.occluded(&ray, &mut one, &mut alone);
                assert_eq!(one[0], occluded, "{accel}: slot {slot}, ray {i}");
            }
            let mut hits = Hits::default();
            let mut packet = TraversalStats::default();
            bvh.intersect(&rays, &mut hits, &mut packet, None);
            // Per-ray costs asked for: every ray walks alone.
            let mut single = TraversalStats::default();
            let mut cost = vec![0; rays.len()];
            bvh.intersect(&rays, &mut hits, &mut single, Some(&mut cost));
            let what = format!("{accel}: slot {slot} (kind {kind})");
            if kind == 0 {
                assert!(
                    packet.nodes_visited >= 8,
                    "{what}: every ray visits the root"
                );
                assert_eq!(packet.nodes_visited % 8, 0, "{what}");
                assert_eq!(packet.primitives_tested % 8, 0, "{what}");
                assert!(!hits.is_hit(0) || packet.primitives_tested >= 8, "{what}");
                if occluded[0] {
                    stopped_together += 1;
                    assert_eq!(counts(&bundled), counts(&alone), "{what}: bundled vs alone");
                }
            }
            if occluded.iter().all(|&o| !o) {
                unhit += 1;
                unhit_packets += usize::from(kind == 2);
                assert_eq!(counts(&bundled), counts(&alone), "{what}: bundled vs alone");
                assert_eq!(counts(&single), counts(&alone), "{what}: closest vs any");
                assert_eq!(counts(&packet), counts(&alone), "{what}: packet vs alone");
            }
        }
    }
    // Enough slots of each kind for the comparisons to mean something.
    assert!(
        stopped_together >= 40 && unhit >= 80 && unhit_packets >= 20,
        "{stopped_together}, {unhit}, {unhit_packets}"
    );
}

/// What a structure reports about itself (`--stats` prints it): its
/// kind, a tree of several wide levels over 1000 triangles in groups of
/// eight, at least a cache line per node and per group. Rays that miss
/// the scene's bounds cost one node visit each, on both queries, in full
/// and partly filled batch slots.
#[test]
fn structure_sizes_and_missed_rays() {
    let mut rng = Rng(0xc0ff_ee11);
    let tris = random_tris(&mut rng, 1000, Vec3::splat(2.0), 4.0, 0.2);
    let g = soup(tris, Vec::new());
    let mut away = Rays::default();
    for i in 0..20 {
        away.push(
            Vec3::new(-1.0, 0.1 * i as f32, 0.0),
            -Vec3::X,
            f32::INFINITY,
        );
    }
    for accel in [Accel::Sah, Accel::Median, Accel::None] {
        let bvh = Bvh::build(&g, accel);
        assert_eq!(bvh.accel(), accel);
        let groups = bvh.triangle_group_count();
        assert!(
            (1000usize.div_ceil(8)..=1000).contains(&groups),
            "{accel}: {groups}"
        );
        let (nodes, depth) = (bvh.node_count(), bvh.depth());
        if accel == Accel::None {
            assert_eq!((nodes, depth), (0, 0));
        } else {
            assert!(
                nodes >= 1000 / 64 && (2..=nodes).contains(&depth),
                "{accel}: {nodes}, {depth}"
            );
        }
        assert!(bvh.memory_bytes() >= 64 * (nodes + groups), "{accel}");
        let mut stats = TraversalStats::default();
        bvh.intersect(&away, &mut Hits::default(), &mut stats, None);
        let mut occluded = Vec::new();
        bvh.occluded(&away, &mut occluded, &mut stats);
        assert!(occluded.iter().all(|&o| !o));
        if accel != Accel::None {
            assert_eq!(stats.nodes_visited, 2 * away.len() as u64, "{accel}");
            assert_eq!(stats.primitives_tested, 0, "{accel}");
        }
    }
}

/// Small deterministic generator (xorshift32) for the real-mesh rays.
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
    fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next())
    }
}

/// `n` random triangles for `soup`: a corner in the cube of side `size`
/// around `centre`, two edge vectors with components within ±`edge`/2.
fn random_tris(
    rng: &mut Rng,
    n: usize,
    centre: Vec3,
    size: f32,
    edge: f32,
) -> Vec<(Vec3, Vec3, Vec3)> {
    let around = |rng: &mut Rng, c: Vec3, s: f32| c + (rng.vec3() - Vec3::splat(0.5)) * s;
    (0..n)
        .map(|_| {
            let corner = around(rng, centre, size);
            (
                corner,
                around(rng, Vec3::ZERO, edge),
                around(rng, Vec3::ZERO, edge),
            )
        })
        .collect()
}

/// Real meshes from the CS184 scene collection, when present: camera rays
/// plus random rays starting inside the scene bounds.
#[test]
fn real_meshes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/cs184");
    if !dir.is_dir() {
        println!("skipping real_meshes: {} not found", dir.display());
        return;
    }
    for name in [
        "sky/CBbunny.dae",
        "sky/CBspheres.dae",
        "meshedit/cow.dae",
        "keenan/banana.dae",
    ] {
        let path = dir.join(name);
        let scene = match wavepath::scene::collada::load_file(&path) {
            Ok(s) => s,
            Err(e) => panic!("loading {}: {e}", path.display()),
        };
        let bounds = scene.geometry.bounds();
        let mut rng = Rng(0x9e37_79b9);
        let mut rays = Rays::default();
        let view = scene.camera.view(64, 48);
        for y in 0..48 {
            for x in 0..64 {
                let d = scene
                    .camera
                    .direction(&view, x as f32 + 0.5, y as f32 + 0.5);
                rays.push(scene.camera.position, d, f32::INFINITY);
            }
        }
        for _ in 0..1000 {
            let o = bounds.min + rng.vec3() * bounds.diagonal();
            let d = rng.vec3() * 2.0 - Vec3::ONE;
            let t_max = if rng.next() < 0.5 {
                f32::INFINITY
            } else {
                rng.next() * bounds.diagonal().length()
            };
            rays.push(o, d, t_max);
        }
        let hits = compare(&scene.geometry, &rays).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(hits > 0, "{name}: no hits at all");
    }
}

/// What an f64 oracle, independent of wavepath's triangle and sphere code,
/// says a ray hits: `Some(Some((prim, t)))` for a clear closest hit,
/// `Some(None)` for a clear miss, `None` when rounding could decide (a hit
/// within 1e-5 of an edge, of t = 0 or of t_max, a grazed sphere, or two
/// primitives within a relative 1e-4 of each other along the ray).
fn oracle(geometry: &Geometry, o: Vec3, d: Vec3, t_max: f32) -> Option<Option<(u32, f64)>> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let t_max = t_max as f64;
    let scale = d.length();
    // (t, prim) of clear hits; `unsure` when a candidate is on a boundary.
    let mut hits: Vec<(f64, u32)> = Vec::new();
    let (mut unsure, mut in_plane) = (false, false);
    let mut consider = |t: f64, prim: u32, margin_ok: bool| {
        let t_margin = 1e-5 * (1.0 + t.abs()) / scale;
        if t < -t_margin || t > t_max + t_margin {
            return;
        }
        if !margin_ok || t < t_margin || (t_max.is_finite() && t > t_max - t_margin) {
            unsure = true;
        } else {
            hits.push((t, prim));
        }
    };
    let tris = &geometry.triangles;
    for (k, idx) in tris.indices.iter().enumerate() {
        let [a, b, c] = idx.map(|i| tris.positions[i as usize].as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-9 * e1.length() * e2.length() * scale {
            // Parallel to the plane: a miss, unless the ray runs in it.
            let n = e1.cross(e2).normalize();
            in_plane |= (o - a).dot(n).abs() < 1e-5 * (1.0 + (o - a).length());
            continue;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        let w = 1.0 - u - v;
        let inside = u.min(v).min(w);
        if inside < -1e-5 {
            continue;
        }
        consider(t, k as u32, inside > 1e-5);
    }
    let spheres = &geometry.spheres;
    for k in 0..spheres.center.len() {
        let (c, r) = (spheres.center[k].as_dvec3(), spheres.radius[k] as f64);
        let oc = o - c;
        let (a, b, cc) = (d.dot(d), oc.dot(d), oc.dot(oc) - r * r);
        let disc = b * b - a * cc;
        if disc < -1e-6 * b * b {
            continue;
        }
        let root = disc.max(0.0).sqrt();
        let prim = (tris.indices.len() + k) as u32;
        let clear = disc > 1e-6 * b * b;
        for t in [(-b - root) / a, (-b + root) / a] {
            consider(t, prim, clear);
        }
    }
    unsure |= in_plane;
    hits.sort_by(|x, y| x.0.total_cmp(&y.0));
    // The nearest candidate of each sphere is its entry (or, inside, its exit).
    let first = hits.first().copied();
    if let Some((t, prim)) = first {
        let tie = hits
            .iter()
            .any(|&(u, p)| p != prim && u <= t * (1.0 + 1e-4) + 1e-9);
        if unsure || tie {
            return None;
        }
        return Some(Some((prim, t)));
    }
    if unsure { None } else { Some(None) }
}

/// Every structure against the f64 oracle on random soups of triangles and
/// spheres: the same primitive and t within 1e-4 (relative) for closest
/// hits, and any-hit agreeing, on every ray the oracle is sure about. The
/// other tests compare the structures with `Accel::None`, which shares the
/// per-primitive arithmetic; this one shares nothing with it.
#[test]
fn every_structure_agrees_with_an_independent_f64_oracle() {
    let mut rng = Rng(0x1234_5678);
    let (mut sure, mut hit) = (0usize, 0usize);
    for round in 0..6 {
        let tris: Vec<(Vec3, Vec3, Vec3)> = (0..400)
            .map(|_| {
                let a = rng.vec3() * 10.0;
                let size = if round % 2 == 0 { 5.0 } else { 2.0 };
                (a, (rng.vec3() - 0.5) * size, (rng.vec3() - 0.5) * size)
            })
            .collect();
        let spheres: Vec<(Vec3, f32)> = (0..25)
            .map(|_| (rng.vec3() * 10.0, 0.1 + rng.next() * 1.2))
            .collect();
        let g = soup(tris, spheres);
        let mut rays = Rays::default();
        for i in 0..4000 {
            let o = rng.vec3() * 14.0 - 2.0;
            let d = rng.vec3() - 0.5;
            let t_max = if i % 3 == 0 {
                rng.next() * 8.0
            } else {
                f32::INFINITY
            };
            rays.push(o, d * (0.5 + rng.next() * 4.0), t_max);
        }
        for accel in [Accel::None, Accel::Median, Accel::Sah] {
            let bvh = Bvh::build(&g, accel);
            let (mut hits, mut occ) = (Hits::default(), Vec::new());
            let mut stats = TraversalStats::default();
            bvh.intersect(&rays, &mut hits, &mut stats, None);
            bvh.occluded(&rays, &mut occ, &mut stats);
            #[allow(clippy::needless_range_loop)] // i indexes the rays and both results
            for i in 0..rays.len() {
                let (o, d) = (rays.origin(i), rays.direction(i));
                let Some(expected) = oracle(&g, o, d, rays.t_max[i]) else {
                    continue;
                };
                if accel == Accel::Sah {
                    sure += 1;
                    hit += usize::from(expected.is_some());
                }
                let what = format!(
                    "{accel}, round {round}, ray {i} ({o} + t {d}, t_max {})",
                    rays.t_max[i]
                );
                match expected {
                    None => assert!(
                        hits.prim[i] == NO_HIT && !occ[i],
                        "{what}: hit prim {} at {}, occluded {}, the oracle sees nothing",
                        hits.prim[i],
                        hits.t[i],
                        occ[i]
                    ),
                    Some((prim, t)) => {
                        assert_eq!(
                            hits.prim[i], prim,
                            "{what}: t {} vs the oracle's {t}",
                            hits.t[i]
                        );
                        let rel = (hits.t[i] as f64 - t).abs() / t.max(1e-30);
                        assert!(rel <= 1e-4, "{what}: t {} vs {t}", hits.t[i]);
                        assert!(occ[i], "{what}: not occluded");
                    }
                }
            }
        }
    }
    eprintln!("{sure} rays decided by the oracle, {hit} of them hits");
    // Most rays are decided, and both outcomes are well represented.
    assert!(sure > 6 * 4000 * 9 / 10, "only {sure} rays decided");
    assert!(hit > sure / 5 && hit < sure * 4 / 5, "{hit} of {sure} hit");
}

/// Rays leaving a large tilted floor from points near the origin, moved
/// off it by `offset_from_surface` with the floor triangle's reach, never
/// hit the floor again, at any scale: the bound follows the triangle's
/// size, not the point's coordinates (which alone leave a share of such
/// rays inside the floor's error band).
#[test]
fn rays_offset_from_a_surface_by_its_reach_leave_it() {
    let mut rng = Rng(0x0bad_5eed);
    let n = Vec3::new(0.13, 1.0, -0.07).normalize();
    let (u, v) = n.any_orthonormal_pair();
    for scale in [1e-3f32, 1.0, 1e3, 1e5] {
        let s = 100.0 * scale;
        let corners = [(-s, -s), (s, -s), (s, s), (-s, s)].map(|(a, b)| a * u + b * v);
        let g = geometry(corners.to_vec(), vec![[0, 1, 2], [0, 2, 3]], Vec::new());
        let bvh = Bvh::build(&g, Accel::Sah);
        let mut rays = Rays::default();
        for _ in 0..20_000 {
            // On the plane near its middle (rounded to f32 once), where
            // p's own coordinates are small next to the floor's size.
            let (a, b) = (rng.next() as f64 - 0.5, rng.next() as f64 - 0.5);
            let p = ((a * u.as_dvec3() + b * v.as_dvec3()) * scale as f64).as_vec3();
            let o = offset_from_surface(p, n, surface_reach(p, &corners));
            // Grazing: nearly along the floor, slightly up.
            let along = (rng.next() - 0.5) * u + (rng.next() - 0.5) * v;
            let d = along + n * (rng.next() * 1e-3 + 1e-6);
            rays.push(o, d, f32::INFINITY);
        }
        let (mut hits, mut occ) = (Hits::default(), Vec::new());
        bvh.intersect(&rays, &mut hits, &mut TraversalStats::default(), None);
        bvh.occluded(&rays, &mut occ, &mut TraversalStats::default());
        let again = hits.prim.iter().filter(|&&p| p != NO_HIT).count();
        assert_eq!(
            again, 0,
            "scale {scale}: {again} rays hit the floor they left"
        );
        assert!(occ.iter().all(|&o| !o), "scale {scale}");
    }
}

/// Long thin triangles: a fan of 100 slivers, 10 long and 0.03 wide at
/// their broad end, meeting at one apex, flat on y = 0. Where the edge
/// functions' products dwarf a sliver's determinant, the distance weighed
/// from them is far off (half the true one, outside the triangle's own
/// box). Camera-like rays under a lid 5e-5 above the fan agree with brute
/// force in every structure, and shadow rays leaving points of the fan
/// (offset by its reach, as the renderer offsets them) toward a light
/// above it agree too and meet nothing: the fan lies wholly below them.
/// Without the slivers' distances taken from the plane in f64, the
/// shadow rays met the fan. Once as it is (a scene of slivers: walked
/// carefully), once among 10,082 well-shaped triangles far below (one
/// sliver in a hundred: walked fast, the rays that meet a sliver twice).
#[test]
fn slivers_agree_with_brute_force_and_release_their_shadow_rays() {
    for diluted in [false, true] {
        slivers_among(diluted);
    }
}

/// [`slivers_agree_with_brute_force_and_release_their_shadow_rays`], with
/// or without the well-shaped triangles.
fn slivers_among(diluted: bool) {
    let n = 100u32;
    let mut positions = vec![Vec3::new(0.0, 0.0, -8.0)];
    positions.extend((0..=n).map(|i| Vec3::new(-1.5 + 3.0 * i as f32 / n as f32, 0.0, 2.0)));
    let fan: Vec<[u32; 3]> = (0..n).map(|i| [0, i + 1, i + 2]).collect();
    let mut rng = Rng(77);
    // With `diluted`, a grid of 71 × 71 squares 5 below the fan appended.
    let scene = |mut positions: Vec<Vec3>, mut indices: Vec<[u32; 3]>| {
        if diluted {
            let k = 71;
            let first = positions.len() as u32;
            for j in 0..=k {
                for i in 0..=k {
                    positions.push(Vec3::new(i as f32 - 35.5, -5.0, j as f32 - 35.5));
                }
            }
            let at = |i: u32, j: u32| first + j * (k + 1) + i;
            for j in 0..k {
                for i in 0..k {
                    indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                    indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
        let g = geometry(positions, indices, Vec::new());
        let walk = Bvh::build(&g, Accel::Sah).sliver_walk();
        assert_eq!(walk, if diluted { "fast" } else { "careful" });
        g
    };

    let lid = |x: f32, z: f32| Vec3::new(x, 5e-5, z);
    let mut covered = positions.clone();
    covered.extend([
        lid(-3.0, -10.0),
        lid(3.0, 4.0),
        lid(3.0, -10.0),
        lid(-3.0, 4.0),
    ]);
    let k = n + 2;
    let mut indices = fan.clone();
    indices.extend([[k, k + 1, k + 2], [k, k + 3, k + 1]]);
    let covered = scene(covered, indices);
    let eye = Vec3::new(0.0, 1.0, 3.0);
    let mut rays = Rays::default();
    for _ in 0..4000 {
        let target = Vec3::new((rng.next() - 0.5) * 0.6, 0.0, -7.0 + 8.0 * rng.next());
        rays.push(eye, (target - eye).normalize(), f32::INFINITY);
    }
    compare(&covered, &rays).unwrap();
    // And the answer itself: the lid, 5e-5 above the fan, is what every
    // ray meets first.
    let mut hits = Hits::default();
    Bvh::build(&covered, Accel::None).intersect(
        &rays,
        &mut hits,
        &mut TraversalStats::default(),
        None,
    );
    assert!(
        hits.prim.iter().all(|&p| p == n || p == n + 1),
        "a ray went under the lid"
    );

    // The same rays without the lid meet the fan itself (or, past its
    // edges, the grid far below).
    let floor = scene(positions.clone(), fan.clone());
    compare(&floor, &rays).unwrap();
    Bvh::build(&floor, Accel::None).intersect(
        &rays,
        &mut hits,
        &mut TraversalStats::default(),
        None,
    );
    let on_fan = hits.prim.iter().filter(|&&p| p < n).count();
    assert!(on_fan > 3000, "{on_fan} of 4000 rays met the fan");
    // Shadow rays from below, whose only occluder is the fan.
    let mut rays = Rays::default();
    for _ in 0..4000 {
        let o = Vec3::new((rng.next() - 0.5) * 0.6, -1.0, -5.0 + 6.0 * rng.next());
        rays.push(o, Vec3::new(0.0, 3.0, 0.0) - o, 1.0);
    }
    compare(&floor, &rays).unwrap();
    let mut occluded = Vec::new();
    let bvh = Bvh::build(&floor, Accel::Sah);
    bvh.occluded(&rays, &mut occluded, &mut TraversalStats::default());
    let blocked = occluded.iter().filter(|&&o| o).count();
    assert!(
        blocked > 3000,
        "{blocked} of 4000 rays from below were blocked"
    );

    let light = Vec3::new(0.0, 3.0, 0.0);
    let mut rays = Rays::default();
    for _ in 0..4000 {
        let tri = fan[(rng.next() * n as f32) as usize].map(|v| positions[v as usize]);
        let (r1, r2) = (rng.next().sqrt(), rng.next());
        let p = tri[0] * (1.0 - r1) + tri[1] * (r1 * (1.0 - r2)) + tri[2] * (r1 * r2);
        let o = offset_from_surface(p, Vec3::Y, surface_reach(p, &tri));
        rays.push(o, light - o, 1.0);
    }
    assert_eq!(compare(&floor, &rays), Ok(0), "shadow rays met the fan");
}

/// A sliver whose f32 distance overshoots its true one still wins over a
/// surface between the two, whichever of them a walk meets first (a
/// review's case: a ray leaving just above a floor, meeting a sliver of
/// the fan at 2.03e-6 whose f32 distance reads 8.18e-6, with a floor
/// 1e-6 lower at 4.04e-6). When the floor came first, the sliver's f32
/// distance lay beyond the nearest hit so far and it was never measured
/// again: brute force (which tests in id order) and packets answered the
/// floor, the hierarchy the sliver.
#[test]
fn a_sliver_nearer_than_its_f32_distance_wins_in_any_order() {
    let sliver = [
        Vec3::new(0.0, 0.0, -8.0),
        Vec3::new(-1.44, 0.0, 2.0),
        Vec3::new(-1.41, 0.0, 2.0),
    ];
    let floor = [
        Vec3::new(-3.0, -1e-6, -4.0),
        Vec3::new(3.0, -1e-6, -4.0),
        Vec3::new(0.0, -1e-6, -2.0),
    ];
    // Eight small triangles far off, so that brute force's first group
    // holds the floor and its second the sliver (or the other way).
    let far: Vec<[Vec3; 3]> = (0..8)
        .map(|i| {
            let c = Vec3::new(100.0 + 3.0 * i as f32, 50.0, 0.0);
            [c, c + Vec3::X, c + Vec3::Y]
        })
        .collect();
    let o = Vec3::new(-0.678_682_1, 1e-6, -3.232_565_2);
    let d = Vec3::new(-0.039_571_06, -0.491_550_83, 1.0);
    let mut rays = Rays::default();
    for _ in 0..8 {
        rays.push(o, d, f32::INFINITY);
    }
    for sliver_first in [false, true] {
        let mut tris = Vec::new();
        let (first, second) = if sliver_first {
            (sliver, floor)
        } else {
            (floor, sliver)
        };
        tris.push(first);
        tris.extend(far.iter().copied());
        tris.push(second);
        let sliver_id = if sliver_first { 0 } else { 9 };
        let positions: Vec<Vec3> = tris.iter().flatten().copied().collect();
        let indices = (0..tris.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        let g = geometry(positions, indices, Vec::new());
        compare(&g, &rays).unwrap();
        for accel in ACCELS {
            let mut hits = Hits::default();
            Bvh::build(&g, accel).intersect(&rays, &mut hits, &mut TraversalStats::default(), None);
            assert!(
                hits.prim.iter().all(|&p| p == sliver_id),
                "{accel} (sliver first: {sliver_first}): {:?}",
                hits.prim
            );
        }
    }
}

/// Any-hit and closest-hit queries agree on a sliver met at grazing
/// incidence (a review's case: f32 distance 8.975419, true 8.975747).
/// Any-hit queries once skipped the f64 distance when the f32 one lay
/// inside the range by more than an error bound, which the rounding of
/// the sheared vertices broke here: a ray ending at 8.9755 was occluded
/// yet hit nothing.
#[test]
fn any_hit_and_closest_hit_agree_on_a_grazing_sliver() {
    let positions = vec![
        Vec3::new(4.907_243_7, 2.990_653_5, -0.102_963_25),
        Vec3::new(4.143_017, 2.168_352, 0.636_215_9),
        Vec3::new(4.278_741, 2.313_907_1, 0.494_737_5),
    ];
    let g = geometry(positions, vec![[0, 1, 2]], Vec::new());
    let o = Vec3::new(-0.890_049_1, -3.261_955_3, 5.053_872);
    let d = Vec3::new(0.583_077_5, 0.629_014_13, -0.514_161_3);
    let mut rays = Rays::default();
    for t_max in [8.9755, 8.97575, 8.976, f32::INFINITY] {
        rays.push(o, d, t_max);
    }
    compare(&g, &rays).unwrap();
}

/// Direction components below f32's normal range count as zeros in every
/// query. Their reciprocals overflow, so the box test took such a ray for
/// parallel to the axis while the triangle test did not: a ray starting
/// 1e-44 outside a triangle's edge plane with a 1e-40 component toward it
/// hit in brute force and missed in the hierarchies. Now every structure
/// answers alike (and the ray, moving less than f32 can show, misses).
#[test]
fn subnormal_direction_components_count_as_zero() {
    let tri = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let g = geometry(
        tri.to_vec(),
        vec![[0, 1, 2]],
        vec![(Vec3::new(-3.0, 0.25, 1.0), 0.5)],
    );
    let mut rays = Rays::default();
    for (x, dx) in [
        (-1e-44, 1e-40),
        (1e-44, -1e-40),
        (-1e-44, -1e-40),
        (0.0, 1e-39),
    ] {
        for t_max in [f32::INFINITY, 1.0] {
            rays.push(Vec3::new(x, 0.25, 0.0), Vec3::new(dx, 0.0, 1.0), t_max);
            rays.push(Vec3::new(x, 0.25, 0.0), Vec3::new(dx, -0.0, 1.0), t_max);
        }
    }
    // A ray a normal component away from the edge still hits.
    rays.push(
        Vec3::new(-1e-30, 0.25, 0.0),
        Vec3::new(1e-29, 0.0, 1.0),
        f32::INFINITY,
    );
    // Hits: the eight rays starting on the edge plane or 1e-44 inside it,
    // and the last one; the eight starting 1e-44 outside miss.
    assert_eq!(compare(&g, &rays), Ok(9));
}
