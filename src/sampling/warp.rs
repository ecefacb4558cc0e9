//! Warps from the unit square to directions and surfaces.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Cosine-weighted direction around +z; pdf = cos θ / π.
#[inline]
pub fn cosine_hemisphere(u: f32, v: f32) -> Vec3 {
    let r = u.sqrt();
    let phi = 2.0 * PI * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u).max(0.0).sqrt())
}

/// Uniform direction on the hemisphere around +z; pdf = 1 / 2π.
#[inline]
pub fn uniform_hemisphere(u: f32, v: f32) -> Vec3 {
    let z = u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// An orthonormal basis (t, b, n) around unit vector `n`
/// (Duff et al., "Building an Orthonormal Basis, Revisited", 2017).
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// `local` (z up) expressed in the frame whose z axis is `n`.
#[inline]
pub fn to_world(local: Vec3, n: Vec3) -> Vec3 {
    let (t, b) = basis(n);
    local.x * t + local.y * b + local.z * n
}

/// Uniform point on the unit disk, by Shirley and Chiu's concentric map
/// (keeps strata compact, unlike the polar map).
#[inline]
pub fn concentric_disk(u: f32, v: f32) -> Vec2 {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (
            b,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b),
        )
    };
    r * Vec2::new(theta.cos(), theta.sin())
}
