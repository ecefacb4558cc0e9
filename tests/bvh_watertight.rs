//! Watertightness: rays from inside a closed mesh never escape.
//!
//! Rays are aimed exactly at vertices and at points on shared edges, where a
//! non-watertight test lets rays slip through the crack between two
//! triangles. The meshes are also moved 1e5 units from the origin, where
//! f32 spacing is ~0.008 and rounding in the test is at its worst. And the
//! boxes around triangles never shut out a ray that only touches them at
//! a corner where the triangle test reports a hit.

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

/// Rays that touch a triangle's box only at one corner, the triangle's
/// vertex: they enter the slab of one axis at the very distance at which
/// they leave another's, and the two distances, computed from different
/// planes, round apart by an ulp or so. Where the triangle test reports
/// the touch as a hit, the box test must let the ray in: this is what the
/// exit distance's widening by 1 + 2γ₃ (Ize) is for. Every coordinate is
/// a small integer times a power of two, so each ray passes exactly
/// through the vertex, at every scale.
#[test]
fn rays_grazing_a_box_corner_reach_its_vertex() {
    let mut state = 0x2545_f491u32;
    let mut int = move |range: i32| {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        (state % (2 * range as u32 + 1)) as i32 - range
    };
    let mut touched = 0;
    for scale in [2f32.powi(-10), 1.0, 2f32.powi(16)] {
        for _ in 0..400 {
            let mut vertex = || Vec3::new(int(64) as f32, int(64) as f32, int(64) as f32);
            let p = [vertex(), vertex(), vertex()].map(|v| v * scale);
            let soup = [[0u32, 1, 2]];
            let sah = Bvh::from_triangle_soup(&p, &soup, Accel::Sah);
            let brute = Bvh::from_triangle_soup(&p, &soup, Accel::None);
            let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            let mut rays = Rays::default();
            for _ in 0..64 {
                // Through vertex 0. Along each axis where the vertex lies
                // on one face of the box, the ray crosses that face there,
                // into the box or out of it at random, so that many rays
                // touch the box at the vertex alone.
                let mut d = Vec3::ZERO;
                for a in 0..3 {
                    let step = (1 + int(200).abs()) as f32 * scale;
                    let on_face = (p[0][a] == lo[a]) != (p[0][a] == hi[a]);
                    d[a] = if on_face && int(1) > 0 { -step } else { step };
                }
                rays.push(p[0] - d, d, f32::INFINITY);
            }
            let mut want = Hits::default();
            let mut got = Hits::default();
            let mut stats = TraversalStats::default();
            brute.intersect(&rays, &mut want, &mut stats, None);
            sah.intersect(&rays, &mut got, &mut stats, None);
            let (mut want_occ, mut got_occ) = (Vec::new(), Vec::new());
            brute.occluded(&rays, &mut want_occ, &mut stats);
            sah.occluded(&rays, &mut got_occ, &mut stats);
            for i in 0..rays.len() {
                let what = format!(
                    "triangle {p:?}, ray from {} along {}",
                    rays.origin(i),
                    rays.direction(i)
                );
                assert_eq!(got.is_hit(i), want.is_hit(i), "{what}");
                assert_eq!(got_occ[i], want_occ[i], "{what}");
                touched += usize::from(want.is_hit(i));
            }
        }
    }
    assert!(touched > 1000, "only {touched} rays touched their triangle");
}
