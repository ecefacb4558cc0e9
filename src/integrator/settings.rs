//! Which estimator a render runs.

use crate::scene::Light;

/// What the image shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum View {
    /// Light transport, per `max_depth`, `hemisphere` and `bounces`.
    Path,
    /// Shading normal mapped to colour: (n + 1) / 2, as radiance (a PNG goes through --tonemap, as in the CS184 renderer; an EXR holds it as is).
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

    /// How many of `lights` are point or directional lights that light the
    /// image (they emit, and the path view goes past emission), as (found,
    /// missed). A point or directional light is reached along one direction
    /// only, which a direction drawn from the hemisphere (`-H`) hits with
    /// probability 0, so `-H` misses them all.
    pub fn delta_lights(&self, lights: &[Light]) -> (usize, usize) {
        if self.view != View::Path || self.max_depth == 0 {
            return (0, 0);
        }
        let count = lights
            .iter()
            .filter(|l| l.emits() && matches!(l, Light::Point { .. } | Light::Directional { .. }))
            .count();
        if self.hemisphere {
            (0, count)
        } else {
            (count, 0)
        }
    }

    /// What these settings leave out of the image by construction, for a
    /// warning: light the estimator as asked can never find, which a user
    /// would otherwise take for a bug.
    pub fn blind_spots(&self, lights: &[Light]) -> Vec<String> {
        let mut notes = Vec::new();
        if self.view != View::Path {
            return notes;
        }
        if self.bounces == Bounces::Indirect && self.max_depth < 2 {
            notes.push(format!(
                "--bounces indirect keeps light that bounced twice or more, and -m {} \
                 stops before that: the image is black",
                self.max_depth
            ));
        }
        let (_, delta) = self.delta_lights(lights);
        if delta > 0 {
            notes.push(format!(
                "uniform hemisphere sampling (-H) never finds the scene's {delta} point or \
                 directional light{}, so {} light is missing from the image (light sampling, \
                 without -H, finds {})",
                if delta == 1 { "" } else { "s" },
                if delta == 1 { "its" } else { "their" },
                if delta == 1 { "it" } else { "them" },
            ));
        }
        notes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn blind_spots_name_what_cannot_reach_the_image() {
        // A point light, a sun, a point light that emits nothing, a sky.
        let lights = [
            Light::Point {
                position: Vec3::Y,
                intensity: Vec3::ONE,
            },
            Light::Directional {
                to_light: Vec3::Y,
                radiance: Vec3::ONE,
            },
            Light::Point {
                position: Vec3::Y,
                intensity: Vec3::ZERO,
            },
            Light::Hemisphere {
                radiance: Vec3::ONE,
            },
        ];
        let hemisphere = Settings {
            hemisphere: true,
            ..Settings::default()
        };
        let notes = hemisphere.blind_spots(&lights);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].starts_with("uniform hemisphere sampling (-H) never finds the scene's 2 point or directional lights, so their light"),
            "{notes:?}"
        );
        let one = hemisphere.blind_spots(&lights[..1]);
        assert!(
            one[0].contains("1 point or directional light, so its light"),
            "{one:?}"
        );
        // The sky and a light that emits nothing are no loss; light
        // sampling, emission only and the other views lose nothing.
        assert!(hemisphere.blind_spots(&lights[2..]).is_empty());
        for settings in [
            Settings::default(),
            Settings {
                max_depth: 0,
                ..hemisphere
            },
            Settings {
                view: View::Normals,
                ..hemisphere
            },
        ] {
            assert!(settings.blind_spots(&lights).is_empty(), "{settings:?}");
        }

        for (m, black) in [(0, true), (1, true), (2, false)] {
            let indirect = Settings {
                bounces: Bounces::Indirect,
                max_depth: m,
                ..Settings::default()
            };
            let notes = indirect.blind_spots(&lights[3..]);
            assert_eq!(
                notes.iter().any(|n| n.contains("image is black")),
                black,
                "-m {m}: {notes:?}"
            );
        }
    }
}
