//! The adaptive-sampling convergence test.
//!
//! After every `samples_per_batch` samples a pixel's illuminance samples give
//! a mean μ and variance σ²; the 95% confidence half-width is
//! I = 1.96·σ/√n. The pixel has converged, and leaves the mask, when
//! I ≤ tolerance·μ.

/// Adaptive-sampling settings (`-a samples_per_batch tolerance`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    pub samples_per_batch: u32,
    pub tolerance: f32,
}

/// Whether a pixel with `n` samples, illuminance sum `s1` and sum of
/// squares `s2` has converged.
pub fn converged(n: u32, s1: f64, s2: f64, tolerance: f32) -> bool {
    if n < 2 {
        return false;
    }
    let n = n as f64;
    let mean = s1 / n;
    let variance = ((s2 - s1 * s1 / n) / (n - 1.0)).max(0.0);
    let half_width = 1.96 * (variance / n).sqrt();
    half_width <= tolerance as f64 * mean
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_pixels_converge_and_noisy_ones_do_not() {
        // 32 samples of exactly 1: zero variance.
        assert!(converged(32, 32.0, 32.0, 0.05));
        // Alternating 0 and 2: mean 1, σ ≈ 1.016, I ≈ 0.352 > 0.05.
        assert!(!converged(32, 32.0, 64.0, 0.05));
        assert!(converged(32, 32.0, 64.0, 0.4));
        // A black pixel (μ = 0, σ = 0) has converged: I = 0 ≤ 0.
        assert!(converged(32, 0.0, 0.0, 0.05));
    }

    #[test]
    fn one_sample_never_converges() {
        // With `-a 1 …` the first test comes after one sample, where the
        // sample variance (÷ (n − 1) = 0) is undefined: even a zero-noise
        // looking pixel must take a second sample.
        assert!(!converged(1, 1.0, 1.0, 0.05));
        assert!(!converged(1, 0.0, 0.0, 1e9));
        assert!(!converged(0, 0.0, 0.0, 1e9));
    }

    #[test]
    fn variance_is_the_unbiased_sample_variance() {
        // Two samples, 0 and 2: μ = 1, s² = ((0−1)² + (2−1)²)/(2 − 1) = 2,
        // so I = 1.96·√(2/2) = 1.96. Dividing by n instead (s² = 1) would
        // give I ≈ 1.39, by n + 1 (s² = 2/3) I ≈ 1.13: a tolerance of 1.9
        // tells them apart, and 2.0 shows n = 2 is tested at all.
        assert!(!converged(2, 2.0, 4.0, 1.9));
        assert!(converged(2, 2.0, 4.0, 2.0));
    }
}
