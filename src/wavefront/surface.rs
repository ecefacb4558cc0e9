//! Stage 3a: where the wave's rays hit — point, normals facing the ray,
//! and how far off the surface new rays must start — eight triangle hits
//! at a time.
//!
//! Per triangle hit this is an f64 plane intersection, two normalisations
//! and an error bound: ~300 instructions as scalar code inside the shading
//! loop. Across paths the same arithmetic fills vector lanes. The hits'
//! [`TriangleRecord`]s (one per triangle, so no index fetch in front) are
//! copied out first, in a pass of independent loads the core overlaps,
//! so the arithmetic never waits on memory. The stage also hands on each
//! hit's material. Sphere hits (rare, and a different formula) stay
//! scalar.

use glam::Vec3;
use wide::{f32x8, f64x4, i32x8};

use crate::lanes::{self, LANES, Vec3x8};
use crate::ray::{Hits, Rays, gamma};
use crate::scene::{Geometry, Primitive, Triangles};

/// Where a ray hit, with normals oriented toward the side it came from.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Geometric normal on the incoming side (unit).
    pub ng: Vec3,
    /// Shading normal, flipped into the same hemisphere as `ng` (unit).
    pub ns: Vec3,
    /// Whether the ray hit the front (the side the geometric normal points to).
    pub front: bool,
    /// How far off the surface to start rays leaving `p` (see
    /// [`offset_by`](crate::ray::offset_by)).
    pub err: f32,
}

/// The surface points of a wave's hits, structure of arrays; entries of
/// rays that missed are unspecified.
#[derive(Clone, Debug, Default)]
pub struct SurfacePoints {
    p: [Vec<f32>; 3],
    ng: [Vec<f32>; 3],
    ns: [Vec<f32>; 3],
    err: Vec<f32>,
    front: Vec<bool>,
    material: Vec<u32>,
    /// Hits of the last [`compute`](Self::compute) (the arrays only grow).
    len: usize,
    /// The hits' triangle records, fetched ahead of the arithmetic.
    fetched: Vec<TriangleRecord>,
}

/// What the stage reads of one triangle — corners, corner normals,
/// material — in one record, built once per render. Through the scene's
/// indexed arrays a hit cost an index fetch and then six vertex fetches
/// from scattered places (two rounds of cache misses, seven lines); here
/// it is one aligned 64-byte record, one cache line (PERF.md: the 80-byte
/// record with f32 normals straddled two lines, and its second line cost
/// ~3% of a render).
///
/// The corner normals are stored as 16-bit signed-normalised integers
/// (error ≤ 1/65534 per component, ~2e-5 rad in direction): shading
/// normals only orient the sampling frame, so this is far below anything
/// an image shows, while positions stay exact (the hit point and its
/// error bound, which keep new rays off the surface, read only those).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct TriangleRecord {
    /// x, y, z of corners 0 and 1, x, y of corner 2.
    head: [f32; 8],
    /// As bits: z of corner 2; the nine normal components (x, y, z of
    /// corners 0, 1, 2) as i16, two per word in words 1..=5, low half
    /// first (word 5's high half is zero); the material in word 6; word 7
    /// zero. Eight records' heads and tails are one 8×8 transpose each
    /// into the lanes the surface stage works in.
    tail: [i32; 8],
}

const _: () = assert!(std::mem::size_of::<TriangleRecord>() == 64);

/// Word of [`TriangleRecord::tail`] holding the material.
const MATERIAL_WORD: usize = 6;
/// Scale of the 16-bit normal components.
const SNORM: f32 = i16::MAX as f32;

impl TriangleRecord {
    fn new(corners: [Vec3; 3], normals: [Vec3; 3], material: u32) -> TriangleRecord {
        let c = corners.map(|v| v.to_array()).concat();
        let mut tail = [0i32; 8];
        tail[0] = c[8].to_bits() as i32;
        let components = normals.map(|v| v.to_array()).concat();
        for (j, &x) in components.iter().enumerate() {
            // The scene's normals are unit (or zero), so the clamp only
            // absorbs rounding; `as u16` keeps a negative value's sign
            // bits out of the word's other half.
            debug_assert!(
                x.abs() <= 1.0 + 1e-5,
                "shading normal not unit: {normals:?}"
            );
            let q = (x.clamp(-1.0, 1.0) * SNORM).round() as i16 as u16 as i32;
            tail[1 + j / 2] |= q << (16 * (j % 2));
        }
        tail[MATERIAL_WORD] = material as i32;
        TriangleRecord {
            head: c[..8].try_into().unwrap(),
            tail,
        }
    }
}

/// [`TriangleRecord`]s of a scene's triangles, by triangle index.
#[derive(Clone, Debug, Default)]
pub struct TriangleRecords(Vec<TriangleRecord>);

impl TriangleRecords {
    pub fn new(tris: &Triangles) -> TriangleRecords {
        TriangleRecords(
            (0..tris.len())
                .map(|t| {
                    let normal =
                        |k: u32| tris.normals.get(k as usize).copied().unwrap_or(Vec3::ZERO);
                    let normals = tris.indices[t].map(normal);
                    TriangleRecord::new(tris.vertices(t), normals, tris.material[t])
                })
                .collect(),
        )
    }

    /// Heap bytes owned.
    pub fn memory_bytes(&self) -> usize {
        self.0.capacity() * std::mem::size_of::<TriangleRecord>()
    }
}

/// [`SurfacePoint`]s of eight hits, one per lane (no `front`).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceLanes {
    pub p: Vec3x8,
    pub ng: Vec3x8,
    pub ns: Vec3x8,
    pub err: L,
}

type L = f32x8;

impl SurfacePoints {
    /// Computes the surface point of every hit of `rays`.
    pub fn compute(
        &mut self,
        geometry: &Geometry,
        records: &TriangleRecords,
        hits: &Hits,
        rays: &Rays,
    ) {
        let n = hits.len();
        self.len = n;
        // Grow only: waves shrink and refill all the time, and resizing
        // down and up again would zero-fill the arrays every wave.
        if self.err.len() < n {
            for v in self.p.iter_mut().chain(&mut self.ng).chain(&mut self.ns) {
                v.resize(n, 0.0);
            }
            self.err.resize(n, 0.0);
            self.front.resize(n, false);
            self.material.resize(n, 0);
        }
        // Every hit's record first, in one pass of independent loads: a
        // record is often a cache miss (64 bytes per triangle, megabytes
        // in all), and here the core overlaps a dozen misses where the
        // arithmetic below would wait for each group's in turn. Hits on
        // no triangle take the first record, and lanes past the last hit
        // the last hit's (their results are overwritten or never read).
        let triangle_count = records.0.len();
        let mut fetched = std::mem::take(&mut self.fetched);
        fetched.clear();
        if let Some(&fallback) = records.0.first() {
            let record = |&prim: &u32| *records.0.get(prim as usize).unwrap_or(&fallback);
            fetched.extend(hits.prim[..n].iter().map(record));
        }
        for start in (0..n).step_by(LANES) {
            let end = (start + LANES).min(n);
            let prims = &hits.prim[start..end];
            if prims.iter().any(|&prim| (prim as usize) < triangle_count) {
                let tail: [TriangleRecord; LANES];
                let corners: &[TriangleRecord; LANES] = match fetched.get(start..start + LANES) {
                    Some(full) => full.try_into().unwrap(),
                    None => {
                        tail = std::array::from_fn(|lane| fetched[(start + lane).min(n - 1)]);
                        &tail
                    }
                };
                self.triangles(corners, hits, rays, start, end);
            }
            // Sphere hits overwrite what their lanes got above.
            for i in start..end {
                if hits.is_hit(i)
                    && let Primitive::Sphere(s) = geometry.primitive(hits.prim[i])
                {
                    let (o, d) = (rays.origin(i), rays.direction(i));
                    let sp = sphere_point(geometry, s, o, d, hits.t[i]);
                    self.set(i, sp);
                    self.material[i] = geometry.spheres.material[s];
                }
            }
        }
        self.fetched = fetched;
    }

    /// The surface point of hit `i`.
    #[inline]
    pub fn get(&self, i: usize) -> SurfacePoint {
        let at = |v: &[Vec<f32>; 3]| Vec3::new(v[0][i], v[1][i], v[2][i]);
        SurfacePoint {
            p: at(&self.p),
            ng: at(&self.ng),
            ns: at(&self.ns),
            front: self.front[i],
            err: self.err[i],
        }
    }

    /// Material of hit `i`.
    #[inline]
    pub fn material(&self, i: usize) -> u32 {
        self.material[i]
    }

    /// Whether hit `i` is on the front of its surface.
    #[inline]
    pub fn front(&self, i: usize) -> bool {
        self.front[i]
    }

    /// The surface points of hits `start..start + 8` (zeros past the last hit).
    #[inline]
    pub fn lanes(&self, start: usize) -> SurfaceLanes {
        let n = self.len;
        fn axes(v: &[Vec<f32>; 3], n: usize) -> [&[f32]; 3] {
            [&v[0][..n], &v[1][..n], &v[2][..n]]
        }
        SurfaceLanes {
            p: Vec3x8::load(axes(&self.p, n), start),
            ng: Vec3x8::load(axes(&self.ng, n), start),
            ns: Vec3x8::load(axes(&self.ns, n), start),
            err: lanes::load(&self.err[..n], start),
        }
    }

    fn set(&mut self, i: usize, sp: SurfacePoint) {
        for axis in 0..3 {
            self.p[axis][i] = sp.p[axis];
            self.ng[axis][i] = sp.ng[axis];
            self.ns[axis][i] = sp.ns[axis];
        }
        self.err[i] = sp.err;
        self.front[i] = sp.front;
    }

    /// Surface points and materials of the triangle hits `start..end`
    /// (their records `corners`, one per lane).
    fn triangles(
        &mut self,
        corners: &[TriangleRecord; LANES],
        hits: &Hits,
        rays: &Rays,
        start: usize,
        end: usize,
    ) {
        // Lane `l` of word `k`: the records' heads and tails, transposed.
        let head = f32x8::transpose(corners.map(|r| f32x8::from(r.head)));
        let tail = f32x8::transpose(corners.map(|r| lanes::from_bits(i32x8::from(r.tail))))
            .map(lanes::to_bits);
        let coord: [L; 9] = std::array::from_fn(|k| match k {
            0..8 => head[k],
            _ => lanes::from_bits(tail[0]),
        });
        let corner = |k: usize| Vec3x8::new(coord[3 * k], coord[3 * k + 1], coord[3 * k + 2]);
        // Normal component j: the low (even j) or high (odd j) half of
        // word 1 + j/2, moved to the top and sign-extended back down by
        // the arithmetic shift.
        let component = |j: usize| {
            let to_top = 16 * (1 - (j % 2) as i32);
            let q = (tail[1 + j / 2] << to_top) >> 16;
            f32x8::from_i32x8(q) * L::splat(1.0 / SNORM)
        };
        let normal =
            |k: usize| Vec3x8::new(component(3 * k), component(3 * k + 1), component(3 * k + 2));
        let load = |v: &[f32]| lanes::load(&v[..end], start);
        let (a, b, c) = (corner(0), corner(1), corner(2));
        let o = Vec3x8::load(
            [&rays.org_x[..end], &rays.org_y[..end], &rays.org_z[..end]],
            start,
        );
        let d = Vec3x8::load(
            [&rays.dir_x[..end], &rays.dir_y[..end], &rays.dir_z[..end]],
            start,
        );
        let (t, u, v) = (load(&hits.t), load(&hits.u), load(&hits.v));
        let w = L::ONE - u - v;

        let (ng, ng_ok) = (b - a).cross(c - a).normalize();
        let ng = Vec3x8::select(ng_ok, ng, Vec3x8::splat(Vec3::Y));
        // The point where the ray meets the triangle's plane, in f64 and
        // rounded once. Interpolating the f32 barycentrics would be off by
        // ~ε times the triangle's size along the surface (0.1 on a 1e6
        // ground plane), and o + t·d by the error of t.
        let p_plane = plane_point(a, b, c, o, d);
        let interpolated = a * w + b * u + c * v;
        let p = Vec3x8::select(p_plane.is_finite(), p_plane, interpolated);

        // Off-plane error of p: its rounding to f32 (½ ULP per axis,
        // bounded by γ₁|p|), the f64 arithmetic before it (≪ 1e-12 of the
        // magnitudes), and above all the rounding of the ray/triangle test
        // that a new ray from near p makes: it works with vertices relative
        // to the ray origin, sheared, so it errs by up to ~γ₈ times the
        // distance R from p to the triangle's farthest vertex.
        let r = (a - p)
            .abs()
            .max((b - p).abs())
            .max((c - p).abs())
            .max_element();
        let err = L::splat(gamma(1)) * ng.abs().dot(p.abs())
            + L::splat(1e-12) * (o.abs().max_element() + (d * t).abs().max_element())
            + L::splat(gamma(8)) * r;

        // Interpolated vertex normal; the geometric one where it vanishes.
        let (na, nb, nc) = (normal(0), normal(1), normal(2));
        let (ns, ns_ok) = (na * w + nb * u + nc * v).normalize();
        let ns = Vec3x8::select(ns_ok, ns, ng);

        let front = ng.dot(d).simd_lt(L::ZERO);
        let ng = Vec3x8::select(front, ng, -ng);
        let flip = ns.dot(ng).simd_lt(L::ZERO);
        let ns = Vec3x8::select(flip, -ns, ns);

        p.store(self.p.each_mut(), start, end);
        ng.store(self.ng.each_mut(), start, end);
        ns.store(self.ns.each_mut(), start, end);
        lanes::store(&mut self.err[..end], start, err);
        let front = front.to_bitmask();
        for (lane, f) in self.front[start..end].iter_mut().enumerate() {
            *f = front & (1 << lane) != 0;
        }
        let material = tail[MATERIAL_WORD].to_array();
        for (m, &word) in self.material[start..end].iter_mut().zip(&material) {
            *m = word as u32;
        }
    }
}

/// `o + t·d` where the ray meets the plane of triangle `abc`, with `t`
/// and the point computed in f64 (four lanes at a time) and rounded once.
fn plane_point(a: Vec3x8, b: Vec3x8, c: Vec3x8, o: Vec3x8, d: Vec3x8) -> Vec3x8 {
    type D = [f64x4; 3];
    let lanes = |v: Vec3x8| [v.x, v.y, v.z].map(L::to_array);
    let (a, b, c, o, d) = (lanes(a), lanes(b), lanes(c), lanes(o), lanes(d));
    let mut out = [[0.0f32; LANES]; 3];
    for half in 0..2 {
        let wide = |v: &[[f32; LANES]; 3]| -> D {
            let mut x = [[0.0f64; 4]; 3];
            for k in 0..3 {
                for l in 0..4 {
                    x[k][l] = v[k][4 * half + l] as f64;
                }
            }
            [f64x4::from(x[0]), f64x4::from(x[1]), f64x4::from(x[2])]
        };
        let (a, b, c, o, d) = (wide(&a), wide(&b), wide(&c), wide(&o), wide(&d));
        let sub = |x: D, y: D| [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
        let dot = |x: D, y: D| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
        let (e1, e2) = (sub(b, a), sub(c, a));
        let n = [
            e1[1] * e2[2] - e2[1] * e1[2],
            e1[2] * e2[0] - e2[2] * e1[0],
            e1[0] * e2[1] - e2[0] * e1[1],
        ];
        let t = dot(sub(a, o), n) / dot(d, n);
        for k in 0..3 {
            let p = (o[k] + t * d[k]).to_array();
            for l in 0..4 {
                out[k][4 * half + l] = p[l] as f32;
            }
        }
    }
    Vec3x8::new(out[0].into(), out[1].into(), out[2].into())
}

/// The surface point of a sphere hit.
fn sphere_point(geometry: &Geometry, i: usize, origin: Vec3, dir: Vec3, t: f32) -> SurfacePoint {
    let s = &geometry.spheres;
    let (c, r) = (s.center[i], s.radius[i]);
    // Relative to the centre: o − c is exact when both are far from the
    // origin (Sterbenz), so the normal is accurate to the sphere's size,
    // not to the float spacing of o + t·d (1/128 at 1e5, 10% of the
    // shading on a unit sphere there).
    let n = ((origin - c) + t * dir).normalize_or(Vec3::Y);
    // Reproject onto the sphere to cancel the error of o + t·d. What is
    // left: rounding c + r·n (γ₁ of |c| + r) and |n| ≠ 1 (γ₂ r), and the
    // error of the ray/sphere test from the new origin, whose
    // inside/outside decision |o − c|² − r² errs by ~γ₃ r² (a distance of
    // γ₃ r) after o − c errs by γ₁ r.
    let err = gamma(8) * (c.abs().max_element() + r);
    let front = n.dot(dir) < 0.0;
    SurfacePoint {
        p: c + r * n,
        ng: if front { n } else { -n },
        ns: if front { n } else { -n },
        front,
        err,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::NO_HIT;

    /// The per-hit scalar formulation the vector stage replaced, kept as
    /// the reference it must reproduce: bit for bit, but for the shading
    /// normal, read from 16-bit components.
    fn scalar_triangle_point(
        tris: &crate::scene::Triangles,
        i: usize,
        (u, v): (f32, f32),
        origin: Vec3,
        dir: Vec3,
        t: f32,
    ) -> SurfacePoint {
        let [a, b, c] = tris.vertices(i);
        let ng = crate::lanes::normalize_any_scale((b - a).cross(c - a)).unwrap_or(Vec3::Y);
        let (a64, o64, d64) = (a.as_dvec3(), origin.as_dvec3(), dir.as_dvec3());
        let n64 = (b.as_dvec3() - a64).cross(c.as_dvec3() - a64);
        let t64 = (a64 - o64).dot(n64) / d64.dot(n64);
        let p64 = (o64 + t64 * d64).as_vec3();
        let p = if p64.is_finite() {
            p64
        } else {
            (1.0 - u - v) * a + u * b + v * c
        };
        let r = (a - p)
            .abs()
            .max((b - p).abs())
            .max((c - p).abs())
            .max_element();
        let err = gamma(1) * ng.abs().dot(p.abs())
            + 1e-12 * (origin.abs().max_element() + (t * dir).abs().max_element())
            + gamma(8) * r;
        let ns = tris.shading_normal(i, u, v);
        let front = ng.dot(dir) < 0.0;
        let ng = if front { ng } else { -ng };
        let ns = if ns.dot(ng) < 0.0 { -ns } else { ns };
        SurfacePoint {
            p,
            ng,
            ns,
            front,
            err,
        }
    }

    #[test]
    fn vector_stage_matches_the_scalar_formulas() {
        let mut g = Geometry::default();
        let t = &mut g.triangles;
        // A tilted triangle far from the origin, one at the origin, a
        // degenerate one (all vertices equal, zero normals), a sliver.
        t.positions = vec![
            Vec3::new(1e4, 2e4, -3e4),
            Vec3::new(1e4 + 3.0, 2e4 + 0.5, -3e4),
            Vec3::new(1e4, 2e4 + 2.0, -3e4 + 1.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(5.0, 5.0, 5.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1e-3, 0.0, 1.0),
        ];
        // Negative components in both halves of the records' packed words.
        t.normals = vec![
            Vec3::new(0.0, 0.6, 0.8),
            Vec3::new(0.0, -0.8, 0.6),
            Vec3::new(-0.6, 0.0, 0.8),
            Vec3::Z,
            -Vec3::Z,
            Vec3::Z,
            Vec3::ZERO,
            Vec3::X,
            Vec3::X,
        ];
        t.indices = vec![[0, 1, 2], [3, 4, 5], [6, 6, 6], [7, 8, 3]];
        t.material = vec![3, 0, 7, 1];
        g.spheres.center = vec![Vec3::new(0.0, 0.0, -10.0)];
        g.spheres.radius = vec![2.0];
        g.spheres.material = vec![5];
        let sphere = 4u32;

        let (mut rays, mut hits) = (Rays::default(), Hits::default());
        let mut add = |o: Vec3, d: Vec3, prim: u32, t: f32, u: f32, v: f32| {
            rays.push(o, d, f32::INFINITY);
            hits.t.push(t);
            hits.prim.push(prim);
            hits.u.push(u);
            hits.v.push(v);
        };
        // 13 hits: two full groups of eight would hide tail handling.
        for k in 0..13u32 {
            let s = k as f32 * 0.07;
            match k % 5 {
                0 => add(
                    Vec3::new(1e4, 2e4, 0.0),
                    Vec3::new(0.1 + s, 0.3, -1.0),
                    0,
                    3e4,
                    0.2,
                    0.3,
                ),
                1 => add(Vec3::new(0.2, 0.1 + s, 5.0), -Vec3::Z, 1, 5.0, 0.2, 0.1 + s),
                2 => add(Vec3::new(0.2, 0.3, -1.0), Vec3::Z, 1, 1.0, 0.2 + s, 0.3),
                3 => add(
                    Vec3::new(0.0, 0.0, 5.0),
                    Vec3::X,
                    2 + (k & 1),
                    1.0,
                    0.3,
                    0.3,
                ),
                _ => add(
                    Vec3::ZERO,
                    -Vec3::Z,
                    if k == 4 { sphere } else { NO_HIT },
                    8.0,
                    0.0,
                    0.0,
                ),
            }
        }
        let mut points = SurfacePoints::default();
        points.compute(&g, &TriangleRecords::new(&g.triangles), &hits, &rays);
        for i in 0..hits.len() {
            let (o, d, t) = (rays.origin(i), rays.direction(i), hits.t[i]);
            let expected = match g.primitive(hits.prim[i]) {
                _ if !hits.is_hit(i) => continue,
                Primitive::Triangle(tri) => {
                    scalar_triangle_point(&g.triangles, tri, (hits.u[i], hits.v[i]), o, d, t)
                }
                Primitive::Sphere(s) => sphere_point(&g, s, o, d, t),
            };
            let got = points.get(i);
            let material = match g.primitive(hits.prim[i]) {
                Primitive::Triangle(tri) => g.triangles.material[tri],
                Primitive::Sphere(s) => g.spheres.material[s],
            };
            assert_eq!(points.material(i), material, "hit {i} material");
            let bits = |sp: &SurfacePoint| [sp.p, sp.ng].map(|v| v.to_array().map(f32::to_bits));
            assert_eq!(
                bits(&got),
                bits(&expected),
                "hit {i}: {got:?} vs {expected:?}"
            );
            // The records' 16-bit normals: each component within 1/65534,
            // so a unit shading normal is off by well under 1e-4.
            assert!(
                (got.ns - expected.ns).length() < 1e-4 && got.ns.is_normalized(),
                "hit {i} ns: {got:?} vs {expected:?}"
            );
            assert_eq!(got.err.to_bits(), expected.err.to_bits(), "hit {i} err");
            assert_eq!(got.front, expected.front, "hit {i} front");
        }
    }

    /// `--stats` reports the records' memory: one 64-byte record per
    /// triangle, and not a whole spare allocation more.
    #[test]
    fn records_report_their_memory() {
        let n = 100;
        let tris = Triangles {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            indices: vec![[0, 1, 2]; n],
            material: vec![0; n],
            ..Triangles::default()
        };
        let bytes = TriangleRecords::new(&tris).memory_bytes();
        assert!(
            (64 * n..128 * n).contains(&bytes),
            "{bytes} bytes for {n} records"
        );
    }

    #[test]
    fn normals_of_huge_and_tiny_triangles_are_theirs_not_the_fallback() {
        // Edges of 1e10 square to 1e20 in the cross product and to 1e40,
        // past f32, in its squared length; edges of 1e-12 underflow.
        for scale in [1e-12f32, 1.0, 1e10, 1e15] {
            let mut g = Geometry::default();
            let t = &mut g.triangles;
            t.positions = vec![Vec3::ZERO, Vec3::X * scale, Vec3::Y * scale];
            t.normals = vec![Vec3::ZERO; 3];
            t.indices = vec![[0, 1, 2]];
            t.material = vec![0];
            let (mut rays, mut hits) = (Rays::default(), Hits::default());
            let o = Vec3::new(0.25, 0.25, 1.0) * scale;
            rays.push(o, -Vec3::Z, f32::INFINITY);
            hits.t.push(scale);
            hits.prim.push(0);
            hits.u.push(0.25);
            hits.v.push(0.25);
            let mut points = SurfacePoints::default();
            points.compute(&g, &TriangleRecords::new(&g.triangles), &hits, &rays);
            let sp = points.get(0);
            assert_eq!((sp.ng, sp.ns), (Vec3::Z, Vec3::Z), "scale {scale}");
            assert!(sp.front, "scale {scale}");
        }
    }
}
