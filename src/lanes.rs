//! Eight lanes at a time: loads and stores between structure-of-arrays
//! buffers and `wide::f32x8` registers, and [`Vec3x8`], eight 3-vectors
//! one register per axis, for the stages that shade eight paths at once.
//!
//! A batch's last group of lanes may be partial, so the natural
//! `f32x8::from(&v[start..end])` takes a slice of run-time length, which
//! compiles to a call to `memcpy` (and spills the registers around it) at
//! every group — millions of calls per render. These take a fixed-size
//! path for full groups and the slice path only for the tail.

use glam::Vec3;
use wide::{f32x8, i32x8};

/// Lanes per register.
pub const LANES: usize = 8;

/// `[f(0), f(1), f(2)]`: one value per axis, always inlined. The same as
/// `[0, 1, 2].map(f)` where the optimiser inlines `array::map`, which in
/// the traversal's per-node box tests it once stopped doing (an
/// out-of-line `try_map` per child test made maxplanck's primary rays a
/// third slower; PERF.md, BVH, third session of 2026-11-27).
#[inline(always)]
pub fn per_axis<T>(f: impl Fn(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}

/// Lanes `start..start + 8` of `v`; past its end, zeros.
#[inline(always)]
pub fn load(v: &[f32], start: usize) -> f32x8 {
    match v.get(start..start + 8) {
        Some(full) => f32x8::from(<[f32; 8]>::try_from(full).unwrap()),
        None => f32x8::from(&v[start..]),
    }
}

/// Writes the lanes of `x` to `v[start..]`, as many as fit.
#[inline(always)]
pub fn store(v: &mut [f32], start: usize, x: f32x8) {
    match v.get_mut(start..start + 8) {
        Some(full) => {
            let full: &mut [f32; 8] = full.try_into().unwrap();
            *full = x.to_array();
        }
        None => {
            let tail = &mut v[start..];
            let n = tail.len();
            tail.copy_from_slice(&x.to_array()[..n]);
        }
    }
}

/// [`store`] for sixteen lanes: the two halves of `x` at `start` and
/// `start + 8`, as many lanes as fit.
#[inline(always)]
pub fn store_x16(v: &mut [f32], start: usize, x: wide::f32x16) {
    let a = x.to_array();
    let (lo, hi) = a.split_at(8);
    store(v, start, f32x8::from(<[f32; 8]>::try_from(lo).unwrap()));
    if start + 8 < v.len() {
        store(v, start + 8, f32x8::from(<[f32; 8]>::try_from(hi).unwrap()));
    }
}

/// Appends the first `n` entries of `group` to `v`. A whole group is a
/// copy of constant size (straight vector moves); only a partial one takes
/// a run-time length (a call to `memcpy`).
#[inline(always)]
pub fn extend<T: Copy>(v: &mut Vec<T>, group: &[T; LANES], n: usize) {
    if n == LANES {
        v.extend_from_slice(group);
    } else {
        v.extend_from_slice(&group[..n]);
    }
}

/// Lane masks as bits (lane `l` is bit `l`), lowest lane first.
#[inline(always)]
pub fn each(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            lane
        })
    })
}

/// All-ones lanes for the bits of `mask` (the inverse of `to_bitmask`).
#[inline(always)]
pub fn lane_mask(mask: u32) -> f32x8 {
    let bits: [i32; LANES] = std::array::from_fn(|l| -(((mask >> l) & 1) as i32));
    from_bits(i32x8::from(bits))
}

/// The bits of `x`, as integers (for sign and ULP tricks).
#[inline(always)]
pub fn to_bits(x: f32x8) -> i32x8 {
    wide::bytemuck::cast(x)
}

/// The floats with bit patterns `x`.
#[inline(always)]
pub fn from_bits(x: i32x8) -> f32x8 {
    wide::bytemuck::cast(x)
}

/// Eight 3-vectors, one register per axis. The arithmetic is glam's,
/// operation for operation (dot products summed x + y + z, maxima as
/// `if a > b { a } else { b }`, which is what `maxps` computes), so a
/// lane holds exactly what the same expression on `Vec3` would give.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vec3x8 {
    pub x: f32x8,
    pub y: f32x8,
    pub z: f32x8,
}

impl Vec3x8 {
    #[inline(always)]
    pub fn new(x: f32x8, y: f32x8, z: f32x8) -> Self {
        Vec3x8 { x, y, z }
    }

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        Vec3x8::new(f32x8::splat(v.x), f32x8::splat(v.y), f32x8::splat(v.z))
    }

    /// Lanes `start..start + 8` of a structure-of-arrays vector (zeros past its end).
    #[inline(always)]
    pub fn load(axes: [&[f32]; 3], start: usize) -> Self {
        Vec3x8::new(
            load(axes[0], start),
            load(axes[1], start),
            load(axes[2], start),
        )
    }

    /// Writes the lanes to `axes[k][start..end]`, as many as fit.
    #[inline(always)]
    pub fn store(self, axes: [&mut Vec<f32>; 3], start: usize, end: usize) {
        let [x, y, z] = axes;
        store(&mut x[..end], start, self.x);
        store(&mut y[..end], start, self.y);
        store(&mut z[..end], start, self.z);
    }

    /// The vectors of `v` (up to eight; zeros past its end), one per lane.
    #[inline(always)]
    pub fn gather(v: &[Vec3]) -> Self {
        Vec3x8::from_fn(v.len().min(LANES), |lane| v[lane])
    }

    /// `f(lane)` in the first `n` lanes, zeros in the rest. (Written into
    /// per-axis arrays directly: going through a `[Vec3; 8]` compiled to
    /// a second copy.)
    #[inline(always)]
    pub fn from_fn(n: usize, f: impl Fn(usize) -> Vec3) -> Self {
        let mut xyz = [[0.0f32; LANES]; 3];
        #[allow(clippy::needless_range_loop)] // `lane` indexes three arrays
        for lane in 0..n.min(LANES) {
            let p = f(lane);
            (xyz[0][lane], xyz[1][lane], xyz[2][lane]) = (p.x, p.y, p.z);
        }
        Vec3x8::new(xyz[0].into(), xyz[1].into(), xyz[2].into())
    }

    /// The vector in `lane`.
    #[inline(always)]
    pub fn lane(&self, lane: usize) -> Vec3 {
        Vec3::new(
            self.x.as_array()[lane],
            self.y.as_array()[lane],
            self.z.as_array()[lane],
        )
    }

    /// The eight vectors.
    #[inline(always)]
    pub fn to_array(self) -> [Vec3; LANES] {
        let (x, y, z) = (self.x.to_array(), self.y.to_array(), self.z.to_array());
        std::array::from_fn(|l| Vec3::new(x[l], y[l], z[l]))
    }

    #[inline(always)]
    pub fn dot(self, o: Self) -> f32x8 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    pub fn length_squared(self) -> f32x8 {
        self.dot(self)
    }

    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Vec3x8::new(
            self.y * o.z - o.y * self.z,
            self.z * o.x - o.z * self.x,
            self.x * o.y - o.x * self.y,
        )
    }

    #[inline(always)]
    pub fn abs(self) -> Self {
        Vec3x8::new(self.x.abs(), self.y.abs(), self.z.abs())
    }

    /// Largest component, as glam's `max_element`: max(x, max(y, z))
    /// with `max(a, b) = if a > b { a } else { b }`.
    #[inline(always)]
    pub fn max_element(self) -> f32x8 {
        self.x.fast_max(self.y.fast_max(self.z))
    }

    /// Componentwise maximum, as glam's `max` (`if a > b { a } else { b }`).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        Vec3x8::new(
            self.x.fast_max(o.x),
            self.y.fast_max(o.y),
            self.z.fast_max(o.z),
        )
    }

    /// All-ones lanes where every component is finite.
    #[inline(always)]
    pub fn is_finite(self) -> f32x8 {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite()
    }

    /// `if_true` in the lanes where `mask` is all ones, else `if_false`.
    #[inline(always)]
    pub fn select(mask: f32x8, if_true: Self, if_false: Self) -> Self {
        Vec3x8::new(
            mask.select(if_true.x, if_false.x),
            mask.select(if_true.y, if_false.y),
            mask.select(if_true.z, if_false.z),
        )
    }

    /// `x / |x|` and the lanes where that is a usable unit vector
    /// (finite, non-zero length), as [`normalize_any_scale`] lane by lane.
    #[inline(always)]
    pub fn normalize(self) -> (Self, f32x8) {
        let m = to_bits(self.abs().max_element());
        let exponent = m & i32x8::splat(EXPONENT_BITS);
        let scale = i32x8::splat(ONE_SCALE_BITS) - exponent.min(i32x8::splat(MAX_SCALED_EXPONENT));
        let v = self * from_bits(scale);
        let rcp = f32x8::ONE / v.length_squared().sqrt();
        (v * rcp, rcp.is_finite() & rcp.simd_gt(f32x8::ZERO))
    }
}

/// The exponent field of an f32.
const EXPONENT_BITS: i32 = 0x7f80_0000;
/// Bits of 2^(127 − E) are this minus the bits of 2^E.
const ONE_SCALE_BITS: i32 = 0x7f00_0000;
/// The largest exponent field scaled exactly (2^126): the factor for it,
/// 2^−126, is the smallest normal power of two.
const MAX_SCALED_EXPONENT: i32 = 0x7e80_0000;

/// `v / |v|`, or `None` where that is not a usable unit vector (zero,
/// non-finite), at any scale of `v`.
///
/// A cross product of two edges grows with the square of the scene's
/// size, and its squared length with the fourth power: in f32 that
/// overflows past edges of ~1e9 (the normal of a triangle 1e10 across
/// would come out zero) and underflows below ~1e-10. So `v` is first
/// multiplied by the power of two 2^(127 − E) that brings its largest
/// component m = 1.f·2^E into [1, 2) (at the top of the range into
/// [2, 4); a subnormal m, whose exponent field is 0, into [2^−22, 2)).
/// Wherever the plain normalisation works, this gives the same bits:
/// scaling by a power of two is exact for the largest components and
/// `|s·v| = s·|v|` rounds as `|v|` does (a component scaled down into the
/// subnormals may lose a last bit, far below anything a normal shows).
#[inline]
pub fn normalize_any_scale(v: Vec3) -> Option<Vec3> {
    let m = v.abs().max_element().to_bits() as i32;
    let scale = ONE_SCALE_BITS - (m & EXPONENT_BITS).min(MAX_SCALED_EXPONENT);
    let v = v * f32::from_bits(scale as u32);
    let rcp = 1.0 / v.length_squared().sqrt();
    (rcp.is_finite() && rcp > 0.0).then_some(v * rcp)
}

impl std::ops::Add for Vec3x8 {
    type Output = Vec3x8;
    #[inline(always)]
    fn add(self, o: Vec3x8) -> Vec3x8 {
        Vec3x8::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl std::ops::Sub for Vec3x8 {
    type Output = Vec3x8;
    #[inline(always)]
    fn sub(self, o: Vec3x8) -> Vec3x8 {
        Vec3x8::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

/// Componentwise product.
impl std::ops::Mul for Vec3x8 {
    type Output = Vec3x8;
    #[inline(always)]
    fn mul(self, o: Vec3x8) -> Vec3x8 {
        Vec3x8::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

impl std::ops::Mul<f32x8> for Vec3x8 {
    type Output = Vec3x8;
    #[inline(always)]
    fn mul(self, s: f32x8) -> Vec3x8 {
        Vec3x8::new(self.x * s, self.y * s, self.z * s)
    }
}

impl std::ops::Div<f32x8> for Vec3x8 {
    type Output = Vec3x8;
    #[inline(always)]
    fn div(self, s: f32x8) -> Vec3x8 {
        Vec3x8::new(self.x / s, self.y / s, self.z / s)
    }
}

impl std::ops::Neg for Vec3x8 {
    type Output = Vec3x8;
    #[inline(always)]
    fn neg(self) -> Vec3x8 {
        Vec3x8::new(-self.x, -self.y, -self.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maxima_are_glams() {
        // NaN in every position, ±0 both ways round: the lanes must pick
        // exactly what glam picks.
        let vals = [1.0, -2.0, 0.0, -0.0, f32::NAN, f32::INFINITY];
        let bits = |x: f32| if x.is_nan() { u32::MAX } else { x.to_bits() };
        for a in vals {
            for b in vals {
                let vs: [Vec3; LANES] =
                    std::array::from_fn(|l| Vec3::new(a, b, vals[l % vals.len()]));
                let ws: [Vec3; LANES] =
                    std::array::from_fn(|l| Vec3::new(vals[l % vals.len()], a, b));
                let (v, w) = (Vec3x8::gather(&vs), Vec3x8::gather(&ws));
                let (m, e) = (v.max(w), v.max_element());
                for l in 0..LANES {
                    let want = vs[l].max(ws[l]).to_array().map(bits);
                    assert_eq!(
                        m.lane(l).to_array().map(bits),
                        want,
                        "max {:?} {:?}",
                        vs[l],
                        ws[l]
                    );
                    assert_eq!(
                        bits(e.as_array()[l]),
                        bits(vs[l].max_element()),
                        "{:?}",
                        vs[l]
                    );
                }
            }
        }
    }

    #[test]
    fn full_and_partial_groups() {
        let v: Vec<f32> = (0..11).map(|i| i as f32).collect();
        assert_eq!(load(&v, 0).to_array(), [0., 1., 2., 3., 4., 5., 6., 7.]);
        assert_eq!(load(&v, 8).to_array(), [8., 9., 10., 0., 0., 0., 0., 0.]);
        let mut out = vec![-1.0; 11];
        store(&mut out, 0, load(&v, 0));
        store(&mut out, 8, load(&v, 8));
        assert_eq!(out, v);
    }

    #[test]
    fn normalisation_works_at_any_scale_and_keeps_glams_bits_where_glam_works() {
        let directions = [
            Vec3::new(0.3, -0.4, 1.2),
            Vec3::new(-1.0, 1e-4, 2e-3),
            Vec3::new(0.0, 0.0, -7.0),
            Vec3::new(5.0, 5.0, 5.0),
        ];
        for d in directions {
            let expected = d.normalize();
            // Scales whose squared length glam's f32 normalisation survives:
            // the same bits (power-of-two prescaling is exact).
            for scale in [1e-12f32, 1e-3, 1.0, 3.7, 1e6, 1e12] {
                let v = d * scale;
                assert_eq!(normalize_any_scale(v), Some(v.normalize()), "{v}");
            }
            // Scales where it overflows or underflows: still the unit vector.
            for scale in [1e-30f32, 1e-22, 1e20, 1e30, 1e37] {
                let v = d * scale;
                assert!(v.normalize_or_zero() == Vec3::ZERO || scale < 1e20);
                let got = normalize_any_scale(v).unwrap();
                assert!((got - expected).length() < 1e-6, "{v}: {got}");
                assert!(got.is_normalized());
            }
        }
        for bad in [
            Vec3::ZERO,
            Vec3::new(f32::NAN, 1.0, 0.0),
            Vec3::new(0.0, f32::INFINITY, 1.0),
        ] {
            assert_eq!(normalize_any_scale(bad), None, "{bad}");
        }
        // Subnormal components.
        let tiny = Vec3::new(1e-44, -2e-44, 0.0);
        let got = normalize_any_scale(tiny).unwrap();
        assert!(
            (got - Vec3::new(1.0, -2.0, 0.0).normalize()).length() < 0.1,
            "{got}"
        );
    }

    #[test]
    fn a_lane_is_finite_only_when_all_three_components_are() {
        // One bad component in each position, each kind of bad, and a
        // lane with none: the mask must be glam's `is_finite` lane by lane.
        let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
        let mut vs = [Vec3::new(1.0, -2.0, 3.0); LANES];
        for (lane, v) in vs.iter_mut().enumerate().skip(1) {
            v[(lane - 1) % 3] = bad[(lane - 1) / 3 % 3];
        }
        let mask = Vec3x8::gather(&vs).is_finite().to_bitmask();
        for (lane, v) in vs.iter().enumerate() {
            assert_eq!(mask & (1 << lane) != 0, v.is_finite(), "{v}");
        }
    }

    #[test]
    fn lane_normalisation_is_the_scalar_one() {
        let vs: [Vec3; LANES] = [
            Vec3::new(0.3, -0.4, 1.2),
            Vec3::new(1e20, -3e19, 2e20),
            Vec3::new(1e-30, 0.0, -1e-31),
            Vec3::ZERO,
            Vec3::new(f32::NAN, 1.0, 0.0),
            Vec3::new(3e38, 3e38, 1.0),
            Vec3::new(0.0, f32::INFINITY, 0.0),
            Vec3::new(1e-44, 1e-44, 1e-44),
        ];
        let (unit, ok) = Vec3x8::gather(&vs).normalize();
        let ok = ok.to_bitmask();
        for (lane, v) in vs.iter().enumerate() {
            match normalize_any_scale(*v) {
                Some(u) => {
                    assert!(ok & (1 << lane) != 0, "{v}");
                    let bits = |w: Vec3| w.to_array().map(f32::to_bits);
                    assert_eq!(bits(unit.lane(lane)), bits(u), "{v}");
                }
                None => assert!(ok & (1 << lane) == 0, "{v}"),
            }
        }
    }
}
