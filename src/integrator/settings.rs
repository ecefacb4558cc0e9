//! Which estimator a render runs.

/// What the image shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum View {
    /// Light transport, per `max_depth`, `hemisphere` and `bounces`.
    Path,
    /// Shading normal mapped to colour: (n + 1) / 2.
    Normals,
    /// Heat map of BVH traversal steps (nodes visited + primitives tested) per pixel.
    BvhCost,
}

/// Which bounces of light a path estimator adds to the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Bounces {
    /// Every bounce from 0 to `max_depth` (the default).
    Accumulate,
    /// Only light that bounced exactly `max_depth` times.
    Last,
    /// Everything but emission seen directly and direct lighting (bounces ≥ 2).
    Indirect,
}

/// Estimator settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pub view: View,
    /// `-m`: bounces. 0 = emission seen directly; 1 = plus direct lighting;
    /// k = next-event estimation at the first k path vertices.
    pub max_depth: u32,
    /// `-l`: samples per area light (and per hemisphere light / emissive mesh).
    pub light_samples: u32,
    /// `-H`: direct lighting by uniform hemisphere sampling instead of light sampling.
    pub hemisphere: bool,
    pub bounces: Bounces,
    /// Russian roulette on continuation rays (unbiased).
    pub russian_roulette: bool,
    /// First path vertex (0 = the camera ray's hit) at which roulette may
    /// end a path (see [`ROULETTE_DEPTH`]).
    pub roulette_depth: u32,
}

/// Default [`Settings::roulette_depth`]: the first five bounces always
/// continue, so roulette plays no part up to `-m 6`.
///
/// Measured on CBbunny, `-s 64 -l 1 -m 5` (PERF.md, "Convergence"):
/// playing roulette from the second bounce on (depth 1) made a sample 1.6x
/// cheaper but nearly tripled the relMSE (3.2e-3 vs 1.1e-3), so a given
/// error took 1.8x longer (2.0x once the reference's own noise is
/// removed). In a closed room most of the light has bounced
/// several times, and a path cut short there throws away a large share of
/// its pixel's value. Roulette still bounds the work of deep renders
/// (`-m 10` and beyond).
pub const ROULETTE_DEPTH: u32 = 5;

impl Default for Settings {
    fn default() -> Self {
        Settings {
            view: View::Path,
            max_depth: 1,
            light_samples: 1,
            hemisphere: false,
            bounces: Bounces::Accumulate,
            russian_roulette: true,
            roulette_depth: ROULETTE_DEPTH,
        }
    }
}

impl Settings {
    /// Whether light that has bounced `k` times is added to the image.
    #[inline]
    pub fn counts_bounce(&self, k: u32) -> bool {
        k <= self.max_depth
            && match self.bounces {
                Bounces::Accumulate => true,
                Bounces::Last => k == self.max_depth,
                Bounces::Indirect => k >= 2,
            }
    }
}
