//! Numerically stable ray/sphere intersection.
//!
//! Scenes have few spheres, so they are tested one at a time; what matters
//! is accuracy. The textbook quadratic loses almost all digits when the
//! sphere is small relative to its distance (`b² ≈ 4ac`) and when one root
//! is tiny (catastrophic cancellation in `−b ± √Δ`). Following Haines et
//! al., "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing
//! Gems, 2019), the discriminant is computed from the vector from the centre
//! to the ray's closest approach, and the roots as `c/q` and `q/a` with
//! `q = b + sign(b)·√Δ`, which never subtracts nearly equal numbers.

use glam::Vec3;

/// A sphere in BVH leaf order.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PackedSphere {
    pub center: Vec3,
    pub radius: f32,
    /// Global primitive id.
    pub id: u32,
}

/// Nearest `t` in `[0, t_far]` at which `o + t·d` meets the sphere's
/// surface: the near root, or the far root when the origin is inside.
#[inline]
pub(crate) fn intersect_sphere(s: &PackedSphere, o: Vec3, d: Vec3, t_far: f32) -> Option<f32> {
    let f = o - s.center;
    let a = d.dot(d);
    if a == 0.0 {
        return None;
    }
    // Quadratic a·t² − 2b·t + c = 0 with b = −f·d.
    let b = -f.dot(d);
    let c = f.dot(f) - s.radius * s.radius;
    // Δ/4 = b² − ac = a·(r² − |l|²), l = vector from the centre to the
    // closest point of the line.
    let l = f + (b / a) * d;
    let disc = a * (s.radius * s.radius - l.dot(l));
    if disc < 0.0 || disc.is_nan() {
        return None;
    }
    let q = b + disc.sqrt().copysign(b);
    let (t0, t1) = if q == 0.0 {
        (0.0, 0.0)
    } else {
        let (r0, r1) = (c / q, q / a);
        if r0 <= r1 { (r0, r1) } else { (r1, r0) }
    };
    if t0 >= 0.0 {
        (t0 <= t_far).then_some(t0)
    } else if t1 >= 0.0 && t1 <= t_far {
        Some(t1)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(c: Vec3, r: f32) -> PackedSphere {
        PackedSphere {
            center: c,
            radius: r,
            id: 0,
        }
    }

    #[test]
    fn near_far_and_inside() {
        let s = sphere(Vec3::new(0.0, 0.0, 10.0), 1.0);
        let t = intersect_sphere(&s, Vec3::ZERO, Vec3::Z, f32::INFINITY).unwrap();
        assert!((t - 9.0).abs() < 1e-5);
        // Inside: far root.
        let t = intersect_sphere(&s, Vec3::new(0.0, 0.0, 10.0), Vec3::Z, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-5);
        // Behind.
        assert!(intersect_sphere(&s, Vec3::new(0.0, 0.0, 20.0), Vec3::Z, f32::INFINITY).is_none());
        // Beyond t_far.
        assert!(intersect_sphere(&s, Vec3::ZERO, Vec3::Z, 8.0).is_none());
        // Zero direction.
        assert!(intersect_sphere(&s, Vec3::ZERO, Vec3::ZERO, 8.0).is_none());
    }

    #[test]
    fn small_far_sphere_is_accurate() {
        let s = sphere(Vec3::new(0.0, 0.0, 1.0e4), 1.0e-2);
        let t = intersect_sphere(&s, Vec3::ZERO, Vec3::Z, f32::INFINITY).unwrap();
        assert!((t - (1.0e4 - 1.0e-2)).abs() < 1e-2, "{t}");
    }
}
