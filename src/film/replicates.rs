//! A reference image rendered as independent replicates — the same render
//! with different seeds — and combined, so that its own error can be
//! measured rather than assumed.
//!
//! Why: the samples of one pixel are stratified (Owen-scrambled Sobol), so
//! the textbook variance of their mean, s²/n, overstates the mean's error:
//! stratification cancels most of the smooth variation across a pixel and
//! along low dimensions, which s² counts in full. On a small image at low
//! depth the overstatement is 6–10×. Replicates scrambled independently
//! are independent, identically distributed estimates of every pixel
//! (randomised quasi-Monte Carlo), so the spread of their means is an
//! honest estimate of the combined mean's variance:
//!
//! ```text
//! Var(m̄) ≈ Σₖ (mₖ − m̄)² / (K (K − 1))
//! ```
//!
//! Per pixel that estimate has only K − 1 degrees of freedom — too few for
//! a per-pixel test at a Bonferroni threshold — so the combined image keeps
//! the pooled s²/N in its per-pixel variance (a conservative bound, and
//! what a single render of N samples would have stored), and the spread is
//! averaged over the image into the one figure that needs it: the
//! reference's own relMSE, which `converge` subtracts from its
//! measurements.

use glam::Vec3;

use super::Image;
use super::metrics;

/// Replicates combined into one reference.
pub struct Combined {
    /// The mean of the replicates' means; `variance` is the pooled s²/N of
    /// all their samples, `samples` their total count.
    pub image: Image,
    /// The combined image's own relMSE from the replicates' spread (mean
    /// over pixels and channels of Var(m̄) / (m̄² + ε)); `None` with fewer
    /// than two replicates.
    pub rel_mse: Option<f64>,
}

/// Running sums over renders of one image that differ only in their seed,
/// each with the same number of samples per pixel: a replicate is folded
/// in as soon as it is rendered, so a reference of K replicates holds one
/// image and these sums, not K images.
pub struct Replicates {
    /// `pixels`: the running mean of the replicates' means (Welford);
    /// `variance`: Σ (nₖ − 1) sₖ², the squares within replicates;
    /// `samples`: Σ nₖ.
    running: Image,
    /// Σ (mₖ − m̄)², the squares between replicates (Welford's M₂).
    between: Vec<Vec3>,
    /// Replicates added.
    count: u32,
}

/// Bytes per pixel that [`Replicates`] holds.
pub const BYTES_PER_PIXEL: u64 = Image::BYTES_PER_PIXEL + std::mem::size_of::<Vec3>() as u64;

impl Replicates {
    pub fn new(width: u32, height: u32) -> Self {
        let running = Image::new(width, height);
        let n = running.pixels.len();
        Replicates {
            running,
            between: vec![Vec3::ZERO; n],
            count: 0,
        }
    }

    /// Replicates added so far.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Folds in one more replicate.
    ///
    /// # Panics
    /// If `replicate` differs from the first in size or in a pixel's sample
    /// count.
    pub fn add(&mut self, replicate: &Image) {
        let running = &mut self.running;
        assert!(
            (replicate.width, replicate.height) == (running.width, running.height),
            "replicates of one image have one size"
        );
        // Equal counts make the replicates identically distributed and the
        // pooled formula in `combine` exact (converge renders them without
        // adaptive sampling and keeps only complete ones): each pixel has
        // had `count` times this replicate's samples so far.
        let before = self.count;
        assert!(
            running
                .samples
                .iter()
                .zip(&replicate.samples)
                .all(|(&sum, &n)| sum == before * n),
            "replicates take equal samples in every pixel"
        );
        self.count += 1;
        let k = self.count as f32;
        for i in 0..running.pixels.len() {
            // Welford: the mean and Σ (mₖ − m̄)² in one pass.
            let m = replicate.pixels[i];
            let delta = m - running.pixels[i];
            running.pixels[i] += delta / k;
            self.between[i] += delta * (m - running.pixels[i]);
            // (nₖ − 1) sₖ², with sₖ² = nₖ · (the variance of replicate k's
            // mean).
            let nk = replicate.samples[i] as f32;
            running.variance[i] += replicate.variance[i] * nk * (nk - 1.0).max(0.0);
            running.samples[i] += replicate.samples[i];
        }
    }

    /// The reference the replicates make.
    ///
    /// # Panics
    /// If none was added.
    pub fn combine(self) -> Combined {
        assert!(self.count > 0, "a reference of no replicates");
        let k = self.count as f32;
        let mut image = self.running;
        // The spread of the replicates' means, as the variance of their
        // mean (two replicates at least).
        let rel_mse = (self.count > 1).then(|| {
            let spread = self.between.iter().map(|b| *b / (k * (k - 1.0)));
            metrics::mean_relative_variance(image.pixels.iter().copied().zip(spread))
        });
        for i in 0..image.pixels.len() {
            // Pooled s² over all N samples is (within + n·between)/(N − 1)
            // when every replicate has n samples; its mean's variance is
            // that / N.
            let n = image.samples[i] as f32;
            let within = image.variance[i];
            image.variance[i] = if n > 1.0 {
                (within + n / k * self.between[i]) / ((n - 1.0) * n)
            } else {
                Vec3::ZERO
            };
        }
        Combined { image, rel_mse }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn combine(parts: &[Image]) -> Combined {
        let mut replicates = Replicates::new(parts[0].width, parts[0].height);
        for part in parts {
            replicates.add(part);
        }
        replicates.combine()
    }

    /// An image of one pixel holding `samples`, as the film stores them:
    /// their mean and s²/n.
    fn pixel_of(samples: &[f32]) -> Image {
        let n = samples.len() as f32;
        let mean = samples.iter().sum::<f32>() / n;
        let s2 = samples.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / (n - 1.0).max(1.0);
        let mut image = Image::new(1, 1);
        image.pixels[0] = Vec3::splat(mean);
        image.variance[0] = Vec3::splat(if n > 1.0 { s2 / n } else { 0.0 });
        image.samples[0] = samples.len() as u32;
        image
    }

    #[test]
    fn pooled_variance_is_that_of_all_samples_in_one_render() {
        let samples = [0.3, 1.7, 0.2, 0.9, 2.5, 0.0, 1.1, 0.4, 0.8, 1.3, 0.6, 2.0];
        let whole = pixel_of(&samples);
        for k in [1, 2, 3, 4, 12] {
            let parts: Vec<Image> = samples.chunks(12 / k).map(pixel_of).collect();
            let c = combine(&parts);
            let (got, want) = (c.image.variance[0].x, whole.variance[0].x);
            assert!(
                (got - want).abs() < 1e-6 * want,
                "{k} parts: {got} vs {want}"
            );
            assert!((c.image.pixels[0].x - whole.pixels[0].x).abs() < 1e-6);
            assert_eq!(c.image.samples[0], 12);
            assert_eq!(c.rel_mse.is_some(), k > 1);
        }
        // One sample in all has no variance (not 0/0).
        let one = combine(&[pixel_of(&[0.5])]);
        assert_eq!(one.image.variance[0], Vec3::ZERO);
    }

    #[test]
    fn the_spread_of_the_replicates_gives_the_relmse() {
        // Four replicates whose means are 1, 2, 3 and 2 (mean 2): the
        // spread Σ(m − m̄)² = 2 gives Var(m̄) = 2 / (4·3) = 1/6, whatever
        // their samples' own variance.
        let parts: Vec<Image> = [[0.0, 2.0], [2.0, 2.0], [1.0, 5.0], [2.0, 2.0]]
            .iter()
            .map(|s| pixel_of(s))
            .collect();
        let c = combine(&parts);
        let want = (1.0 / 6.0) / (4.0 + metrics::REL_EPSILON);
        let got = c.rel_mse.unwrap();
        assert!((got - want).abs() < 1e-6 * want, "{got} vs {want}");
    }
}
