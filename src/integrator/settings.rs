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
    /// Russian roulette on continuation rays (unbiased; off only for tests).
    pub russian_roulette: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            view: View::Path,
            max_depth: 1,
            light_samples: 1,
            hemisphere: false,
            bounces: Bounces::Accumulate,
            russian_roulette: true,
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
