//! Watertightness: rays from inside a closed mesh never escape.
//!
//! Rays are aimed exactly at vertices and at points on shared edges, where a
//! non-watertight test lets rays slip through the crack between two
//! triangles. The meshes are also moved 1e5 units from the origin, where
//! f32 spacing is ~0.008 and rounding in the test is at its worst.

use glam::Vec3;
use wavepath::bvh::{Accel, Bvh, TraversalStats};
use wavepath::ray::{Hits, Rays};

/// Icosphere of radius `r` around `c`: an icosahedron subdivided `levels`
/// times with vertices pushed to the sphere. Shared vertices are shared by
/// index, so the mesh is closed.
fn icosphere(levels: u32, c: Vec3, r: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|v| Vec3::from_array(*v).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                (p.len() - 1) as u32
            })
        };
        let mut g = Vec::new();
        for [a, b, c] in f {
            let ab = midpoint(a, b, &mut p);
            let bc = midpoint(b, c, &mut p);
            let ca = midpoint(c, a, &mut p);
            g.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = g;
    }
    (p.into_iter().map(|v| c + r * v).collect(), f)
}

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
