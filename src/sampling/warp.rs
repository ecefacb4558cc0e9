//! Warps from the unit square to directions and surfaces.

use glam::{Vec2, Vec3};

/// `(cos 2πv, sin 2πv)`: the unit vector at `v` turns, for `v` in [0, 1].
///
/// Inline, with no call into libm (whose `sincosf` was 2–3% of a render,
/// and whose call made the shading loop spill its registers): `4v` is
/// rounded to the nearest quarter turn `q`, the rest `θ ∈ [−π/4, π/4]`
/// goes through Taylor polynomials of degree 9 and 10 (truncation error
/// below 2e-9 — θ¹¹/11! and θ¹²/12! at π/4 — far under the f32 rounding
/// of ~6e-8), and the quarter turns
/// are applied exactly by swapping and negating.
#[inline]
pub fn unit_circle(v: f32) -> (f32, f32) {
    let x = 4.0 * v;
    let q = x.round();
    let theta = (x - q) * std::f32::consts::FRAC_PI_2;
    let t2 = theta * theta;
    // Horner form of the series; the constants are reciprocals folded at
    // compile time, so there is no division.
    let term = |k: f32, rest: f32| 1.0 - t2 * (1.0 / k) * rest;
    let sin = theta
        * term(
            2.0 * 3.0,
            term(4.0 * 5.0, term(6.0 * 7.0, term(8.0 * 9.0, 1.0))),
        );
    let cos = term(
        1.0 * 2.0,
        term(
            3.0 * 4.0,
            term(5.0 * 6.0, term(7.0 * 8.0, term(9.0 * 10.0, 1.0))),
        ),
    );
    match (q as i32) & 3 {
        0 => (cos, sin),
        1 => (-sin, cos),
        2 => (-cos, -sin),
        _ => (sin, -cos),
    }
}

/// Cosine-weighted direction around +z; pdf = cos θ / π.
#[inline]
pub fn cosine_hemisphere(u: f32, v: f32) -> Vec3 {
    let r = u.sqrt();
    let (c, s) = unit_circle(v);
    Vec3::new(r * c, r * s, (1.0 - u).max(0.0).sqrt())
}

/// Uniform direction on the hemisphere around +z; pdf = 1 / 2π.
#[inline]
pub fn uniform_hemisphere(u: f32, v: f32) -> Vec3 {
    let z = u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (c, s) = unit_circle(v);
    Vec3::new(r * c, r * s, z)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_circle_matches_sin_and_cos() {
        // Every 2^-20 of a turn plus the ends: within 3e-7 of the f64 values
        // (f32 rounding of v·2π alone is ~2e-7 near a full turn).
        let n = 1u32 << 20;
        for i in 0..=n {
            let v = i as f32 / n as f32;
            let (c, s) = unit_circle(v);
            let phi = std::f64::consts::TAU * v as f64;
            assert!((c as f64 - phi.cos()).abs() < 3e-7, "cos at {v}: {c}");
            assert!((s as f64 - phi.sin()).abs() < 3e-7, "sin at {v}: {s}");
            assert!(((c * c + s * s) as f64 - 1.0).abs() < 4e-7, "norm at {v}");
        }
    }
}
