//! Error metrics between an image and a reference.
//!
//! Why this module exists: every claim that a change to the renderer is
//! correct or faster is, in the end, a number comparing an image with a
//! reference. `wavepath compare`, `wavepath converge`, the image
//! regression tests and the benchmarks all compute those numbers here, in
//! one place and one definition each, so they agree.
//!
//! All metrics are per channel (R, G, B) and overall (the mean over the
//! three channels, or for [`ChannelMetrics::max_error`] the maximum), accumulated
//! in `f64`. The second image is always the reference.
//!
//! - RMSE: √(mean (x − r)²).
//! - relMSE: mean (x − r)² / (r² + ε) with ε = [`REL_EPSILON`] = 0.01,
//!   the usual definition (it keeps black pixels from dominating).
//! - MAPE: mean |x − r| / (|r| + ε), as a percentage, same ε.
//! - max error: max |x − r|.

use glam::Vec3;

use super::Image;

/// The ε in relMSE and MAPE denominators.
pub const REL_EPSILON: f64 = 0.01;

/// Error metrics of one channel (or of all channels together).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChannelMetrics {
    pub rmse: f64,
    pub rel_mse: f64,
    /// Mean absolute percentage error, in percent.
    pub mape: f64,
    pub max_error: f64,
}

/// Metrics per channel (R, G, B) and overall.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Metrics {
    pub channels: [ChannelMetrics; 3],
    pub overall: ChannelMetrics,
}

/// The two images differ in size.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("image is {0}x{1} but the reference is {2}x{3}")]
pub struct SizeMismatch(pub u32, pub u32, pub u32, pub u32);

fn check_size(image: &Image, reference: &Image) -> Result<(), SizeMismatch> {
    if (image.width, image.height) != (reference.width, reference.height)
        || image.pixels.len() != reference.pixels.len()
    {
        return Err(SizeMismatch(
            image.width,
            image.height,
            reference.width,
            reference.height,
        ));
    }
    Ok(())
}

/// All metrics of `image` against `reference`.
pub fn compare(image: &Image, reference: &Image) -> Result<Metrics, SizeMismatch> {
    check_size(image, reference)?;
    let n = image.pixels.len().max(1) as f64;
    let mut sq = [0.0f64; 3];
    let mut rel = [0.0f64; 3];
    let mut ape = [0.0f64; 3];
    let mut max = [0.0f64; 3];
    for (x, r) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (x, r) = (x[c] as f64, r[c] as f64);
            let d = x - r;
            sq[c] += d * d;
            rel[c] += d * d / (r * r + REL_EPSILON);
            ape[c] += d.abs() / (r.abs() + REL_EPSILON);
            // NaN must not vanish in max() (`f64::max` returns the other
            // operand): once met, it stays.
            max[c] = if d.is_nan() || max[c].is_nan() {
                f64::NAN
            } else {
                max[c].max(d.abs())
            };
        }
    }
    let mut m = Metrics::default();
    for c in 0..3 {
        m.channels[c] = ChannelMetrics {
            rmse: (sq[c] / n).sqrt(),
            rel_mse: rel[c] / n,
            mape: 100.0 * ape[c] / n,
            max_error: max[c],
        };
    }
    m.overall = ChannelMetrics {
        rmse: (sq.iter().sum::<f64>() / (3.0 * n)).sqrt(),
        rel_mse: rel.iter().sum::<f64>() / (3.0 * n),
        mape: 100.0 * ape.iter().sum::<f64>() / (3.0 * n),
        max_error: max.iter().copied().fold(0.0, |a, b| {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else {
                a.max(b)
            }
        }),
    };
    Ok(m)
}

/// Overall RMSE of `image` against `reference`.
pub fn rmse(image: &Image, reference: &Image) -> Result<f64, SizeMismatch> {
    compare(image, reference).map(|m| m.overall.rmse)
}

/// Overall relMSE of `image` against `reference`.
pub fn rel_mse(image: &Image, reference: &Image) -> Result<f64, SizeMismatch> {
    compare(image, reference).map(|m| m.overall.rel_mse)
}

/// Overall mean absolute percentage error (percent).
pub fn mape(image: &Image, reference: &Image) -> Result<f64, SizeMismatch> {
    compare(image, reference).map(|m| m.overall.mape)
}

/// Largest absolute difference in any channel.
pub fn max_error(image: &Image, reference: &Image) -> Result<f64, SizeMismatch> {
    compare(image, reference).map(|m| m.overall.max_error)
}

/// The relMSE an image would have against the exact answer, estimated from
/// its own per-pixel variance: mean Var / (x² + ε). For a reference this is
/// its noise floor: measured relMSE against it is, in expectation, the true
/// relMSE plus this.
pub fn rel_mse_from_variance(image: &Image) -> f64 {
    mean_relative_variance(
        image
            .pixels
            .iter()
            .copied()
            .zip(image.variance.iter().copied()),
    )
}

/// Mean over pixels and channels of Var / (x² + ε), from each pixel's
/// (x, Var).
pub fn mean_relative_variance(pixels: impl ExactSizeIterator<Item = (Vec3, Vec3)>) -> f64 {
    let n = 3.0 * pixels.len().max(1) as f64;
    pixels
        .map(|(x, v)| {
            (0..3)
                .map(|c| v[c] as f64 / ((x[c] as f64).powi(2) + REL_EPSILON))
                .sum::<f64>()
        })
        .sum::<f64>()
        / n
}

/// Per-pixel relative error: mean over channels of |x − r| / (|r| + ε).
pub fn relative_error_map(image: &Image, reference: &Image) -> Result<Vec<f32>, SizeMismatch> {
    check_size(image, reference)?;
    Ok(image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(x, r)| {
            let d = (*x - *r).abs() / (r.abs() + Vec3::splat(REL_EPSILON as f32));
            (d.x + d.y + d.z) / 3.0
        })
        .collect())
}

/// Result of [`z_test`]: the two statistics and their verdict.
#[derive(Clone, Debug, PartialEq)]
pub struct ZTest {
    /// Number of pixel channels tested.
    pub count: usize,
    /// Largest |z| and where (x, y, channel).
    pub max_abs_z: f64,
    pub worst: (u32, u32, usize),
    /// Per-pixel threshold: the two-sided Bonferroni bound for `count` tests.
    pub z_threshold: f64,
    /// Global test: Σ(x − r) / √Σ_pixels(Σ_channels sd)², at most standard normal under H₀.
    pub global_z: f64,
    pub global_threshold: f64,
}

impl ZTest {
    /// Whether both tests accept "same expected image".
    pub fn passes(&self) -> bool {
        self.max_abs_z <= self.z_threshold && self.global_z.abs() <= self.global_threshold
    }
}

/// Statistical test that `image` and `reference` have the same expected
/// value, using both images' per-pixel variance of the mean (so both must
/// be independent Monte Carlo estimates, e.g. different seeds). `alpha` is
/// the false-rejection probability of each of the two tests when the
/// estimates are normal (roughly: many samples per pixel).
///
/// With `same_estimator`, both images are taken to be averages of samples
/// of one distribution per pixel (the same estimator, different seeds and
/// sample counts, as a regression test's render and its reference). Then
/// each pixel's per-sample variance is the larger of the two images'
/// estimates (var · n), divided by each image's own n. This matters for
/// rare events: a 256-sample render whose pixel never caught a rare bright
/// path has sample variance 0 and would be "certain" it is dark, while the
/// 8192-sample reference did see those paths and knows the spread. Taking
/// the larger estimate keeps the test conservative. Needs per-pixel sample
/// counts in both images; pixels without them use their own variances.
///
/// 1. Per pixel and channel, z = (x − r)/√(var_x + var_r + floor²); the
///    largest |z| is compared with the Bonferroni threshold Φ⁻¹(1 − α/2N)
///    for N pixel channels. This finds a local error (a wrong region)
///    without any of N tests false-alarming more often than α in total.
///    The small floor (1e-5 + 1e-5·|r|) covers pixels with zero variance in
///    both images (background, a light seen directly) where they agree to
///    float rounding.
/// 2. Globally, Σ(x − r) over all pixels and channels, divided by its
///    standard deviation, is normal by the central limit theorem over
///    independent pixels; a small bias common to the whole image (a
///    missing factor, 3% too bright) is invisible to any single pixel but
///    moves this sum by √N times as much. A pixel's R, G and B come from
///    the same paths, so they are correlated (nearly perfectly in a grey
///    scene) and the variance of their sum is not the sum of variances:
///    we use the upper bound (sd_R + sd_G + sd_B)², which keeps the test's
///    false-rejection rate at or below α (measured: treating channels as
///    independent gave a spread of 1.3 instead of 1 on a grey scene).
///
/// We use the sum of differences and not Stouffer's Σz/√N: a pixel's
/// variance estimate is correlated with its mean (a pixel that missed a
/// rare bright path is both dark and falsely certain), which biases Σz,
/// while Σ var over thousands of pixels is an accurate denominator.
pub fn z_test(
    image: &Image,
    reference: &Image,
    alpha: f64,
    same_estimator: bool,
) -> Result<ZTest, SizeMismatch> {
    check_size(image, reference)?;
    let count = 3 * image.pixels.len();
    let mut max_abs_z = 0.0f64;
    let mut worst = (0, 0, 0);
    let mut sum_d = 0.0f64;
    let mut sum_var = 0.0f64;
    for (i, ((x, r), (vx, vr))) in image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .zip(image.variance.iter().zip(&reference.variance))
        .enumerate()
    {
        let (nx, nr) = (image.samples[i] as f64, reference.samples[i] as f64);
        let pool = same_estimator && nx > 0.0 && nr > 0.0;
        let mut pixel_sd = 0.0f64;
        for c in 0..3 {
            let (x, r) = (x[c] as f64, r[c] as f64);
            let (vx, vr) = (vx[c] as f64, vr[c] as f64);
            let var = if pool {
                let per_sample = (vx * nx).max(vr * nr);
                per_sample / nx + per_sample / nr
            } else {
                vx + vr
            };
            let floor = 1e-5 + 1e-5 * r.abs();
            let z = (x - r) / (var + floor * floor).sqrt();
            if z.is_nan() || z.abs() > max_abs_z {
                max_abs_z = if z.is_nan() { f64::INFINITY } else { z.abs() };
                worst = (i as u32 % image.width, i as u32 / image.width, c);
            }
            sum_d += x - r;
            pixel_sd += var.sqrt();
        }
        // R, G and B of a pixel come from the same paths and are strongly
        // correlated; their sum's variance is at most (Σ sd)² (Cauchy–Schwarz).
        sum_var += pixel_sd * pixel_sd;
    }
    let global_z = sum_d / sum_var.max(f64::MIN_POSITIVE).sqrt();
    Ok(ZTest {
        count,
        max_abs_z,
        worst,
        z_threshold: normal_quantile_upper(alpha / (2.0 * count.max(1) as f64)),
        global_z,
        global_threshold: normal_quantile_upper(alpha / 2.0),
    })
}

/// z such that P(Z > z) = p for a standard normal Z (0 < p < 1), by
/// bisection on the complementary error function (accurate to ~1e-9 in z;
/// this is not a hot path).
pub fn normal_quantile_upper(p: f64) -> f64 {
    let p = p.clamp(1e-300, 1.0 - 1e-16);
    let (mut lo, mut hi) = (-40.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if normal_upper_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// P(Z > z) for a standard normal Z.
pub fn normal_upper_tail(z: f64) -> f64 {
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// Complementary error function (Numerical Recipes' Chebyshev fit,
/// relative error < 1.2e-7 everywhere, valid far into the tail).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(pixels: &[Vec3]) -> Image {
        let mut im = Image::new(pixels.len() as u32, 1);
        im.pixels = pixels.to_vec();
        im
    }

    #[test]
    fn metrics_of_a_known_difference() {
        let r = image(&[Vec3::new(1.0, 0.0, 2.0), Vec3::new(0.5, 0.5, 0.5)]);
        let x = image(&[Vec3::new(1.1, 0.0, 2.0), Vec3::new(0.5, 0.3, 0.5)]);
        let m = compare(&x, &r).unwrap();
        let d_r = 0.1f64;
        let d_g = 0.2f64;
        assert!((m.channels[0].rmse - (d_r * d_r / 2.0).sqrt()).abs() < 1e-6);
        assert!((m.channels[1].rmse - (d_g * d_g / 2.0).sqrt()).abs() < 1e-6);
        assert_eq!(m.channels[2].rmse, 0.0);
        let rel_r = d_r * d_r / (1.0 + 0.01) / 2.0;
        assert!((m.channels[0].rel_mse - rel_r).abs() < 1e-7);
        let rel_g = d_g * d_g / (0.25 + 0.01) / 2.0;
        assert!((m.overall.rel_mse - (rel_r + rel_g) / 3.0).abs() < 1e-7);
        assert!((m.channels[1].mape - 100.0 * (0.2 / 0.51) / 2.0).abs() < 1e-4);
        assert!((m.overall.max_error - 0.2).abs() < 1e-6);
        assert!((m.channels[0].max_error - 0.1).abs() < 1e-6);
    }

    #[test]
    fn identical_images_have_zero_error_and_size_mismatch_is_an_error() {
        let r = image(&[Vec3::new(1.0, 2.0, 3.0); 4]);
        assert_eq!(compare(&r, &r).unwrap(), Metrics::default());
        let other = image(&[Vec3::ONE; 3]);
        assert_eq!(compare(&other, &r), Err(SizeMismatch(3, 1, 4, 1)));
    }

    #[test]
    fn nan_is_not_hidden() {
        let r = image(&[Vec3::ONE; 2]);
        // Wherever the NaN pixel is, first or last.
        let bad = Vec3::new(f32::NAN, 1.0, 1.0);
        for pixels in [[Vec3::ONE, bad], [bad, Vec3::ONE]] {
            let x = image(&pixels);
            let m = compare(&x, &r).unwrap();
            assert!(m.overall.max_error.is_nan() && m.overall.rmse.is_nan());
            assert!(m.channels[0].max_error.is_nan());
            assert!(!z_test(&x, &r, 1e-3, false).unwrap().passes());
        }
    }

    #[test]
    fn normal_quantiles() {
        for (p, z) in [
            (0.5, 0.0),
            (0.025, 1.959964),
            (1e-6, 4.753424),
            (1e-9, 5.997807),
        ] {
            assert!((normal_quantile_upper(p) - z).abs() < 1e-4, "{p}");
        }
    }

    #[test]
    fn z_test_accepts_agreement_within_noise_and_rejects_offsets() {
        let n = 1000;
        let mut r = Image::new(n, 1);
        let mut x = Image::new(n, 1);
        for i in 0..n as usize {
            // Alternating ±1σ residuals: agreement within noise.
            let s = if i % 2 == 0 { 0.01 } else { -0.01 };
            r.pixels[i] = Vec3::splat(1.0);
            x.pixels[i] = Vec3::splat(1.0 + s);
            r.variance[i] = Vec3::splat(0.5e-4);
            x.variance[i] = Vec3::splat(0.5e-4);
        }
        assert!(z_test(&x, &r, 1e-3, false).unwrap().passes());
        // A 0.3σ shift everywhere: no pixel notices, the global test does.
        let mut shifted = x.clone();
        shifted
            .pixels
            .iter_mut()
            .for_each(|p| *p += Vec3::splat(0.003));
        let t = z_test(&shifted, &r, 1e-3, false).unwrap();
        assert!(t.max_abs_z < t.z_threshold && !t.passes(), "{t:?}");
        // One pixel 10σ off: the per-pixel test notices.
        let mut spot = x.clone();
        spot.pixels[17].y += 0.1;
        let t = z_test(&spot, &r, 1e-3, false).unwrap();
        assert_eq!(t.worst, (17, 0, 1));
        assert!(!t.passes());
    }

    #[test]
    fn same_estimator_borrows_the_larger_per_sample_variance() {
        // A 100-sample pixel that saw nothing (variance 0) against a
        // 10,000-sample reference of mean 0.01 and per-sample variance 0.01.
        let mut x = Image::new(1, 1);
        let mut r = Image::new(1, 1);
        x.samples[0] = 100;
        r.samples[0] = 10_000;
        r.pixels[0] = Vec3::splat(0.01);
        r.variance[0] = Vec3::splat(0.01 / 10_000.0);
        // Own variances: z = 0.01 / 0.001 = 10, a false alarm.
        assert!(!z_test(&x, &r, 1e-3, false).unwrap().passes());
        // Borrowed: var = 0.01/100 + 0.01/10000, z ≈ 0.1.
        let t = z_test(&x, &r, 1e-3, true).unwrap();
        assert!(
            (t.max_abs_z - 0.01 / (0.0001f64 + 0.000001).sqrt()).abs() < 1e-3,
            "{t:?}"
        );
        assert!(t.passes());
    }
}
