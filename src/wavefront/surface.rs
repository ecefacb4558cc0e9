//! Stage 3a: where the wave's rays hit — point, normals facing the ray,
//! and how far off the surface new rays must start — eight triangle hits
//! at a time.
//!
//! Per triangle hit this is an f64 plane intersection, two normalisations
//! and an error bound: ~300 instructions as scalar code inside the shading
//! loop, with two dependent loads (indices, then vertices) in front. Across
//! paths the same arithmetic fills vector lanes, and the gathers of eight
//! hits are independent loads the core overlaps. Sphere hits (rare, and
//! a different formula) stay scalar.

use glam::Vec3;
use wide::{f32x8, f64x4};

use crate::lanes;
use crate::ray::{Hits, Rays, gamma};
use crate::scene::{Geometry, Primitive};

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
}

const LANES: usize = 8;
type L = f32x8;
/// A vector of eight lanes per axis.
type V = [L; 3];

impl SurfacePoints {
    /// Computes the surface point of every hit of `rays`.
    pub fn compute(&mut self, geometry: &Geometry, hits: &Hits, rays: &Rays) {
        let n = hits.len();
        // Grow only: waves shrink and refill all the time, and resizing
        // down and up again would zero-fill the arrays every wave.
        if self.err.len() < n {
            for v in self.p.iter_mut().chain(&mut self.ng).chain(&mut self.ns) {
                v.resize(n, 0.0);
            }
            self.err.resize(n, 0.0);
            self.front.resize(n, false);
        }
        let tris = &geometry.triangles;
        for start in (0..n).step_by(LANES) {
            let end = (start + LANES).min(n);
            // Triangle lanes; the others borrow the first one's vertices
            // (their results are overwritten or never read).
            let mut corners = [None; LANES];
            for (lane, &prim) in hits.prim[start..end].iter().enumerate() {
                corners[lane] = tris.indices.get(prim as usize).copied();
            }
            if let Some(first) = corners.iter().flatten().next().copied() {
                let corners = corners.map(|c| c.unwrap_or(first));
                self.triangles(tris, &corners, hits, rays, start, end);
            }
            for i in start..end {
                if let Primitive::Sphere(s) = geometry.primitive(hits.prim[i])
                    && hits.is_hit(i)
                {
                    let sp =
                        sphere_point(geometry, s, rays.origin(i), rays.direction(i), hits.t[i]);
                    self.set(i, sp);
                }
            }
        }
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

    fn set(&mut self, i: usize, sp: SurfacePoint) {
        for axis in 0..3 {
            self.p[axis][i] = sp.p[axis];
            self.ng[axis][i] = sp.ng[axis];
            self.ns[axis][i] = sp.ns[axis];
        }
        self.err[i] = sp.err;
        self.front[i] = sp.front;
    }

    /// Surface points of the triangle hits `start..end` (vertex indices
    /// `corners` per lane).
    fn triangles(
        &mut self,
        tris: &crate::scene::Triangles,
        corners: &[[u32; 3]; LANES],
        hits: &Hits,
        rays: &Rays,
        start: usize,
        end: usize,
    ) {
        // Plain loops: `array::map` here compiled to element-wise moves.
        let gather = |data: &[Vec3], k: usize| -> V {
            let mut xyz = [[0.0f32; LANES]; 3];
            for (lane, c) in corners.iter().enumerate() {
                let p = data[c[k] as usize];
                (xyz[0][lane], xyz[1][lane], xyz[2][lane]) = (p.x, p.y, p.z);
            }
            v3(|axis| L::from(xyz[axis]))
        };
        let load = |v: &[f32]| lanes::load(&v[..end], start);
        let (a, b, c) = (
            gather(&tris.positions, 0),
            gather(&tris.positions, 1),
            gather(&tris.positions, 2),
        );
        let o = [load(&rays.org_x), load(&rays.org_y), load(&rays.org_z)];
        let d = [load(&rays.dir_x), load(&rays.dir_y), load(&rays.dir_z)];
        let (t, u, v) = (load(&hits.t), load(&hits.u), load(&hits.v));
        let w = L::ONE - u - v;

        let ng = normalize_or_y(cross(sub(b, a), sub(c, a)));
        // The point where the ray meets the triangle's plane, in f64 and
        // rounded once. Interpolating the f32 barycentrics would be off by
        // ~ε times the triangle's size along the surface (0.1 on a 1e6
        // ground plane), and o + t·d by the error of t.
        let p_plane = plane_point(a, b, c, o, d);
        let interpolated = add(add(scale(a, w), scale(b, u)), scale(c, v));
        let plane_ok = p_plane[0].is_finite() & p_plane[1].is_finite() & p_plane[2].is_finite();
        let p = v3(|k| plane_ok.select(p_plane[k], interpolated[k]));

        // Off-plane error of p: its rounding to f32 (½ ULP per axis,
        // bounded by γ₁|p|), the f64 arithmetic before it (≪ 1e-12 of the
        // magnitudes), and above all the rounding of the ray/triangle test
        // that a new ray from near p makes: it works with vertices relative
        // to the ray origin, sheared, so it errs by up to ~γ₈ times the
        // distance R from p to the triangle's farthest vertex.
        let r = max_element(abs(sub(a, p)))
            .fast_max(max_element(abs(sub(b, p))))
            .fast_max(max_element(abs(sub(c, p))));
        let err = L::splat(gamma(1)) * dot(abs(ng), abs(p))
            + L::splat(1e-12) * (max_element(abs(o)) + max_element(abs(scale(d, t))))
            + L::splat(gamma(8)) * r;

        // Interpolated vertex normal; the geometric one where it vanishes.
        let (na, nb, nc) = (
            gather(&tris.normals, 0),
            gather(&tris.normals, 1),
            gather(&tris.normals, 2),
        );
        let n_interp = add(add(scale(na, w), scale(nb, u)), scale(nc, v));
        let (ns, ns_ok) = normalize(n_interp);
        let ns = v3(|k| ns_ok.select(ns[k], ng[k]));

        let front = dot(ng, d).simd_lt(L::ZERO);
        let ng = v3(|k| front.select(ng[k], -ng[k]));
        let flip = dot(ns, ng).simd_lt(L::ZERO);
        let ns = v3(|k| flip.select(-ns[k], ns[k]));

        let store = |dst: &mut Vec<f32>, x: L| lanes::store(&mut dst[..end], start, x);
        for axis in 0..3 {
            store(&mut self.p[axis], p[axis]);
            store(&mut self.ng[axis], ng[axis]);
            store(&mut self.ns[axis], ns[axis]);
        }
        store(&mut self.err, err);
        let front = front.to_bitmask();
        for (lane, f) in self.front[start..end].iter_mut().enumerate() {
            *f = front & (1 << lane) != 0;
        }
    }
}

/// `o + t·d` where the ray meets the plane of triangle `abc`, with `t`
/// and the point computed in f64 (four lanes at a time) and rounded once.
fn plane_point(a: V, b: V, c: V, o: V, d: V) -> V {
    type D = [f64x4; 3];
    let lanes = |v: V| v.map(L::to_array);
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
    v3(|k| L::from(out[k]))
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

/// The vector whose axis `k` is `f(k)`.
#[inline(always)]
fn v3(f: impl Fn(usize) -> L) -> V {
    [f(0), f(1), f(2)]
}

fn sub(x: V, y: V) -> V {
    v3(|k| x[k] - y[k])
}

fn add(x: V, y: V) -> V {
    v3(|k| x[k] + y[k])
}

fn scale(x: V, s: L) -> V {
    v3(|k| x[k] * s)
}

fn abs(x: V) -> V {
    v3(|k| x[k].abs())
}

fn dot(x: V, y: V) -> L {
    x[0] * y[0] + x[1] * y[1] + x[2] * y[2]
}

fn max_element(x: V) -> L {
    x[0].fast_max(x[1]).fast_max(x[2])
}

fn cross(x: V, y: V) -> V {
    [
        x[1] * y[2] - y[1] * x[2],
        x[2] * y[0] - y[2] * x[0],
        x[0] * y[1] - y[0] * x[1],
    ]
}

/// `x / |x|` and where that is a usable unit vector (finite, non-zero length).
fn normalize(x: V) -> (V, L) {
    let rcp = L::ONE / dot(x, x).sqrt();
    let ok = rcp.is_finite() & rcp.simd_gt(L::ZERO);
    (scale(x, rcp), ok)
}

/// `x / |x|`, or +y where `x` has no direction.
fn normalize_or_y(x: V) -> V {
    let (n, ok) = normalize(x);
    let y = [L::ZERO, L::ONE, L::ZERO];
    v3(|k| ok.select(n[k], y[k]))
}
