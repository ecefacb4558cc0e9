//! Warps from the unit square to directions and surfaces.

use glam::{Vec2, Vec3};
use wide::{f32x8, i32x8};

use crate::lanes::{self, Vec3x8};

/// `(cos 2πv, sin 2πv)`: the unit vector at `v` turns, for `v` in [0, 1].
///
/// Inline, with no call into libm (whose `sincosf` was 2–3% of a render,
/// and whose call made the shading loop spill its registers): `4v` is
/// rounded to the nearest quarter turn `q` (halves away from zero), the rest
/// `θ ∈ [−π/4, π/4]` goes through Taylor polynomials of degree 9 and 10
/// (truncation error below 2e-9 — θ¹¹/11! and θ¹²/12! at π/4 — far under
/// the f32 rounding of ~6e-8), and the quarter turns are applied exactly
/// by swapping and negating.
#[inline(always)]
pub fn unit_circle_x8(v: f32x8) -> (f32x8, f32x8) {
    let x = f32x8::splat(4.0) * v;
    // Nearest quarter turn, halves away from zero as `f32::round` does
    // (x − trunc x is exact, so the test is too).
    let whole = x.trunc();
    let sign = (x & f32x8::splat(-0.0)) | f32x8::ONE;
    let q = (x - whole)
        .abs()
        .simd_ge(f32x8::splat(0.5))
        .select(whole + sign, whole);
    let theta = (x - q) * f32x8::splat(std::f32::consts::FRAC_PI_2);
    let t2 = theta * theta;
    // Horner form of the series; the constants are reciprocals folded at
    // compile time, so there is no division.
    let term = |k: f32, rest: f32x8| f32x8::ONE - t2 * f32x8::splat(1.0 / k) * rest;
    let one = f32x8::ONE;
    let sin = theta
        * term(
            2.0 * 3.0,
            term(4.0 * 5.0, term(6.0 * 7.0, term(8.0 * 9.0, one))),
        );
    let cos = term(
        1.0 * 2.0,
        term(
            3.0 * 4.0,
            term(5.0 * 6.0, term(7.0 * 8.0, term(9.0 * 10.0, one))),
        ),
    );
    // Quarter turn q: (cos, sin), (−sin, cos), (−cos, −sin), (sin, −cos).
    let quarter = q.round_int();
    let odd = lanes::from_bits((quarter & i32x8::ONE).simd_eq(i32x8::ONE));
    let (a, b) = (odd.select(sin, cos), odd.select(cos, sin));
    let sign_bit = |negate: i32x8| lanes::from_bits(negate << 30);
    // Bit 1 of q + 1 is set for q = 1, 2 (negate the first); bit 1 of q
    // for q = 2, 3 (negate the second). Shifted into the sign bit.
    (
        a ^ sign_bit((quarter + i32x8::ONE) & i32x8::splat(2)),
        b ^ sign_bit(quarter & i32x8::splat(2)),
    )
}

/// [`unit_circle_x8`] for one value.
#[inline]
pub fn unit_circle(v: f32) -> (f32, f32) {
    let (c, s) = unit_circle_x8(f32x8::splat(v));
    (c.as_array()[0], s.as_array()[0])
}

/// Cosine-weighted directions around +z; pdf = cos θ / π.
#[inline(always)]
pub fn cosine_hemisphere_x8(u: f32x8, v: f32x8) -> Vec3x8 {
    let r = u.sqrt();
    let (c, s) = unit_circle_x8(v);
    Vec3x8::new(r * c, r * s, (f32x8::ONE - u).max(f32x8::ZERO).sqrt())
}

/// [`cosine_hemisphere_x8`] for one pair.
#[inline]
pub fn cosine_hemisphere(u: f32, v: f32) -> Vec3 {
    cosine_hemisphere_x8(f32x8::splat(u), f32x8::splat(v)).lane(0)
}

/// Uniform direction on the hemisphere around +z; pdf = 1 / 2π.
#[inline]
pub fn uniform_hemisphere(u: f32, v: f32) -> Vec3 {
    let z = u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (c, s) = unit_circle(v);
    Vec3::new(r * c, r * s, z)
}

/// Orthonormal bases (t, b, n) around unit vectors `n`
/// (Duff et al., "Building an Orthonormal Basis, Revisited", 2017).
#[inline(always)]
pub fn basis_x8(n: Vec3x8) -> (Vec3x8, Vec3x8) {
    // copysign(1, n.z), sign bit and all (−0 gives −1).
    let sign_mask = lanes::from_bits(i32x8::splat(i32::MIN));
    let sign = (n.z & sign_mask) | f32x8::ONE;
    let a = -f32x8::ONE / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3x8::new(f32x8::ONE + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3x8::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// `local` (z up) expressed in the frames whose z axes are `n`.
#[inline(always)]
pub fn to_world_x8(local: Vec3x8, n: Vec3x8) -> Vec3x8 {
    let (t, b) = basis_x8(n);
    t * local.x + b * local.y + n * local.z
}

/// [`to_world_x8`] for one vector.
#[inline]
pub fn to_world(local: Vec3, n: Vec3) -> Vec3 {
    to_world_x8(Vec3x8::splat(local), Vec3x8::splat(n)).lane(0)
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

    /// The one-value formulas the lane forms replaced, kept as the
    /// reference they must reproduce bit for bit.
    mod scalar {
        use glam::Vec3;

        pub fn unit_circle(v: f32) -> (f32, f32) {
            let x = 4.0 * v;
            let q = x.round();
            let theta = (x - q) * std::f32::consts::FRAC_PI_2;
            let t2 = theta * theta;
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

        pub fn to_world(local: Vec3, n: Vec3) -> Vec3 {
            let sign = 1.0f32.copysign(n.z);
            let a = -1.0 / (sign + n.z);
            let b = n.x * n.y * a;
            let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
            let b = Vec3::new(b, sign + n.y * n.y * a, -n.y);
            local.x * t + local.y * b + local.z * n
        }

        pub fn cosine_hemisphere(u: f32, v: f32) -> Vec3 {
            let r = u.sqrt();
            let (c, s) = unit_circle(v);
            Vec3::new(r * c, r * s, (1.0 - u).max(0.0).sqrt())
        }
    }

    #[test]
    fn lane_forms_are_the_scalar_formulas_bit_for_bit() {
        // Every eighth of a turn (the quarter-turn ties at 1/8, 3/8, ...),
        // their neighbours one ULP away, and a spread of other values,
        // eight different ones per call.
        let mut vs: Vec<f32> = Vec::new();
        for k in 0..=8 {
            let v = k as f32 / 8.0;
            vs.extend([
                v,
                f32::from_bits(v.to_bits().saturating_sub(1)),
                f32::from_bits(v.to_bits() + 1),
            ]);
        }
        vs.extend((0..1000).map(|i| (i as f32 * 0.618_034).fract()));
        let normals = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.0, -1.0, -0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.3, 0.4, 0.866).normalize(),
            Vec3::new(-0.6, 0.0, -0.8),
            Vec3::new(1e-4, -2e-4, -1.0).normalize(),
            Vec3::new(0.2, -0.9, 0.3).normalize(),
        ];
        let n = Vec3x8::from_fn(8, |l| normals[l]);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for chunk in vs.chunks(8) {
            let v: [f32; 8] = std::array::from_fn(|l| chunk[l % chunk.len()]);
            let u: [f32; 8] = std::array::from_fn(|l| v[7 - l].min(0.999_999_9));
            let (c, s) = unit_circle_x8(f32x8::from(v));
            let d = cosine_hemisphere_x8(f32x8::from(u), f32x8::from(v));
            let w = to_world_x8(d, n);
            for l in 0..8 {
                let (sc, ss) = scalar::unit_circle(v[l]);
                assert_eq!(
                    (c.as_array()[l].to_bits(), s.as_array()[l].to_bits()),
                    (sc.to_bits(), ss.to_bits()),
                    "unit_circle({})",
                    v[l]
                );
                let sd = scalar::cosine_hemisphere(u[l], v[l]);
                assert_eq!(
                    bits(d.lane(l)),
                    bits(sd),
                    "cosine_hemisphere({}, {})",
                    u[l],
                    v[l]
                );
                let sw = scalar::to_world(sd, normals[l]);
                assert_eq!(bits(w.lane(l)), bits(sw), "to_world lane {l}");
            }
        }
    }

    #[test]
    fn frames_are_orthonormal_in_every_lane() {
        // Normals near ±z (where the basis formula divides by sign + n.z),
        // ±0 in z, and generic ones, each in its own lane.
        let normals = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, -1.0, -0.0),
            Vec3::new(1e-4, -2e-4, -1.0).normalize(),
            Vec3::new(0.3, 0.4, 0.866).normalize(),
            Vec3::new(-0.6, 0.0, 0.8),
            Vec3::new(0.2, -0.9, -0.3).normalize(),
        ];
        let n = Vec3x8::from_fn(8, |l| normals[l]);
        let (t, b) = basis_x8(n);
        for (l, &nl) in normals.iter().enumerate() {
            let (t, b) = (t.lane(l), b.lane(l));
            for (what, x) in [("|t|", t.length()), ("|b|", b.length())] {
                assert!((x - 1.0).abs() < 1e-5, "lane {l}: {what} = {x}");
            }
            for (what, x) in [("t·b", t.dot(b)), ("t·n", t.dot(nl)), ("b·n", b.dot(nl))] {
                assert!(x.abs() < 1e-5, "lane {l}: {what} = {x}");
            }
            // Right-handed, so local +z maps to n.
            assert!((t.cross(b) - nl).length() < 1e-5, "lane {l}");
            let w = to_world(Vec3::Z, nl);
            assert!((w - nl).length() < 1e-6, "lane {l}: {w}");
        }
    }

    #[test]
    fn cosine_directions_are_unit_and_upward() {
        for i in 0..=64 {
            for j in 0..=64 {
                let (u, v) = (i as f32 / 64.0, j as f32 / 64.0);
                let d = cosine_hemisphere(u.min(0.99999994), v);
                assert!((d.length() - 1.0).abs() < 1e-6, "({u}, {v}): {d}");
                assert!(d.z >= 0.0);
            }
        }
    }

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

    /// The concentric map sends a stratified grid of the square to points
    /// spread uniformly over the unit disk: the radial moments E[r²] = 1/2
    /// and E[r⁴] = 1/3, E[x²] = E[y²] = 1/4, and equal shares in eight
    /// equal sectors. An odd grid puts strata on the square's centre
    /// lines, where the map divides by zero unless it handles the centre.
    #[test]
    fn concentric_disk_is_uniform_over_the_disk() {
        const K: usize = 65;
        let points: Vec<Vec2> = (0..K * K)
            .map(|s| ((s % K) as f32 + 0.5, (s / K) as f32 + 0.5))
            .map(|(i, j)| concentric_disk(i / K as f32, j / K as f32))
            .collect();
        let n = points.len() as f32;
        assert_eq!(concentric_disk(0.5, 0.5), Vec2::ZERO);
        assert!(
            points
                .iter()
                .all(|p| p.is_finite() && p.length() <= 1.0 + 1e-6)
        );
        let at_centre = points.iter().filter(|p| p.length() < 1e-6).count();
        assert_eq!(at_centre, 1, "points sent to the centre");
        // Each quadrant of the square maps onto the same quadrant of the
        // disk (what keeps strata compact).
        for (s, p) in points.iter().enumerate() {
            let (a, b) = (
                (s % K) as f32 - (K / 2) as f32,
                (s / K) as f32 - (K / 2) as f32,
            );
            assert!(p.x * a >= 0.0 && p.y * b >= 0.0, "({a}, {b}) went to {p}");
        }
        let share = |f: &dyn Fn(&Vec2) -> bool| points.iter().filter(|p| f(p)).count() as f32 / n;
        let moment = |f: &dyn Fn(&Vec2) -> f32| points.iter().map(f).sum::<f32>() / n;
        let r2 = moment(&|p| p.length_squared());
        let r4 = moment(&|p| p.length_squared().powi(2));
        assert!(
            (r2 - 0.5).abs() < 2e-3 && (r4 - 1.0 / 3.0).abs() < 2e-3,
            "{r2}, {r4}"
        );
        let sector_of = |p: &Vec2| {
            let angle = p.y.atan2(p.x).rem_euclid(std::f32::consts::TAU);
            (angle / std::f32::consts::FRAC_PI_4) as usize % 8
        };
        for sector in 0..8 {
            let got = share(&|p| sector_of(p) == sector);
            assert!((got - 0.125).abs() < 0.01, "sector {sector}: {got}");
        }
        let (x2, y2) = (moment(&|p| p.x * p.x), moment(&|p| p.y * p.y));
        assert!(
            (x2 - 0.25).abs() < 2e-3 && (y2 - 0.25).abs() < 2e-3,
            "{x2}, {y2}"
        );
    }
}
