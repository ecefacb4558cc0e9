//! Watertightness: rays from inside a closed mesh never escape.
//!
//! Rays are aimed exactly at vertices and at points on shared edges, where a
//! non-watertight test lets rays slip through the crack between two
//! triangles. The meshes are also moved 1e5 units from the origin, where
//! f32 spacing is ~0.008 and rounding in the test is at its worst.

use glam::Vec3;
use wavepath::bvh::{Accel, Bvh, TraversalStats};
use wavepath::ray::{Hits, Rays};

mod common;
use common::mesh::icosphere;

/// Cube `[c − h, c + h]³` with each face an `n × n` grid of quads split into
/// two triangles, vertices shared along the cube's edges.
fn tessellated_cube(n: u32, c: Vec3, h: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut index = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    let mut vertex = |g: [i64; 3], positions: &mut Vec<Vec3>| -> u32 {
        *index.entry(g).or_insert_with(|| {
            let p = Vec3::new(g[0] as f32, g[1] as f32, g[2] as f32) / n as f32 * 2.0 - 1.0;
            positions.push(c + h * p);
            (positions.len() - 1) as u32
        })
    };
    let n = n as i64;
    for axis in 0..3 {
        for side in [0, n] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: i64, dj: i64| {
                        let mut g = [0; 3];
                        g[axis] = side;
                        g[u] = i + di;
                        g[v] = j + dj;
                        g
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
                        .map(|g| vertex(g, &mut positions));
                    tris.push([q[0], q[1], q[2]]);
                    tris.push([q[0], q[2], q[3]]);
                }
            }
        }
    }
    (positions, tris)
}

/// Targets on every vertex and at several fractions along every edge.
fn targets(p: &[Vec3], f: &[[u32; 3]]) -> Vec<Vec3> {
    let mut out: Vec<Vec3> = p.to_vec();
    for &[a, b, c] in f {
        for (x, y) in [(a, b), (b, c), (c, a)] {
            let (x, y) = (p[x as usize], p[y as usize]);
            for s in [0.5, 0.25, 1.0 / 3.0] {
                out.push(x + s * (y - x));
            }
        }
    }
    out
}

fn assert_no_escape(name: &str, p: &[Vec3], f: &[[u32; 3]], origins: &[Vec3]) {
    let targets = targets(p, f);
    for accel in [Accel::Sah, Accel::Median, Accel::None] {
        let bvh = Bvh::from_triangle_soup(p, f, accel);
        for &o in origins {
            let mut rays = Rays::default();
            for &t in &targets {
                // Unnormalised direction straight at the target: the target
                // is at t = 1 up to the rounding of the subtraction.
                rays.push(o, t - o, f32::INFINITY);
            }
            let mut hits = Hits::default();
            let mut stats = TraversalStats::default();
            bvh.intersect(&rays, &mut hits, &mut stats, None);
            let mut occluded = Vec::new();
            bvh.occluded(&rays, &mut occluded, &mut stats);
            for i in 0..rays.len() {
                assert!(
                    hits.is_hit(i),
                    "{name} {accel}: ray from {o:?} towards {:?} escaped",
                    targets[i]
                );
                assert!(
                    occluded[i],
                    "{name} {accel}: shadow ray towards {:?} escaped",
                    targets[i]
                );
            }
        }
    }
}

#[test]
fn icosphere_is_watertight() {
    for c in [Vec3::ZERO, Vec3::new(1.0e5, -1.0e5, 1.0e5)] {
        let (p, f) = icosphere(3, c, 1.0);
        let origins = [
            c,
            c + Vec3::new(0.3, -0.2, 0.1),
            c + Vec3::new(-0.5, 0.4, 0.55),
        ];
        assert_no_escape(&format!("icosphere at {c}"), &p, &f, &origins);
    }
}

#[test]
fn large_icosphere_far_away_is_watertight() {
    let c = Vec3::new(-1.0e5, 2.0e5, 1.0e5);
    let (p, f) = icosphere(2, c, 100.0);
    let origins = [c, c + Vec3::new(30.0, -20.0, 10.0)];
    assert_no_escape("large far icosphere", &p, &f, &origins);
}

#[test]
fn tessellated_cube_is_watertight() {
    for c in [Vec3::ZERO, Vec3::splat(1.0e5)] {
        let (p, f) = tessellated_cube(6, c, 1.0);
        // Off-centre origins, so edge and vertex targets are not axis aligned.
        let origins = [
            c + Vec3::new(0.1, 0.2, 0.3),
            c + Vec3::new(-0.7, 0.45, -0.2),
        ];
        assert_no_escape(&format!("cube at {c}"), &p, &f, &origins);
    }
}
