//! Command-line arguments, compatible with the CS184 renderer's flags.

use std::path::PathBuf;

use clap::Parser;

use crate::bvh::Accel;
use crate::film::output::ToneCurve;
use crate::integrator::{Bounces, View};

/// Most `-l` samples: every path vertex holds this many draws, and its
/// shadow rays, per light, for a whole wave at once (at 1024, ~250 MB per
/// thread and light).
const MAX_LIGHT_SAMPLES: u32 = 1024;
/// Most `-t` worker threads.
const MAX_THREADS: u32 = 1024;

#[derive(Parser, Debug, Clone)]
#[command(
    name = "wavepath",
    version,
    about = "A data-oriented wavefront CPU path tracer for CS184-style COLLADA scenes",
    after_help = "Example: wavepath -s 64 -l 4 -m 5 -r 480 360 -f cbox.png scenes/cornell.dae\n\n\
                  Tools (see `wavepath <tool> --help`):\n  \
                  wavepath compare <image> <reference> [--diff err.png]   error metrics of EXR/PNG images\n  \
                  wavepath converge [options] --ref ref.exr <scene.dae>    error vs time per estimator\n  \
                  wavepath mitsuba [options] <scene.dae> <dir>             the scene for Mitsuba 3 (side-by-side timing)"
)]
pub struct Args {
    /// Scene file (.dae) [default: the built-in Cornell box, scenes/cornell.dae]
    pub scene: Option<PathBuf>,

    /// Camera rays per pixel (the maximum when sampling adaptively)
    #[arg(short = 's', long = "spp", value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: u32,

    /// Samples per area light (and per hemisphere light or emissive mesh)
    #[arg(short = 'l', long = "light-samples", value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=MAX_LIGHT_SAMPLES as i64))]
    pub light_samples: u32,

    /// Worker threads [default: all cores]
    #[arg(short = 't', long = "threads", value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=MAX_THREADS as i64))]
    pub threads: Option<u32>,

    /// Maximum ray depth: bounces of light (0 = emission only, 1 = direct lighting)
    #[arg(short = 'm', long = "max-depth", value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(0..=1000))]
    pub max_depth: u32,

    /// Output image: .png (8-bit, tone-mapped) or .exr (linear float) [default: <scene>.png]
    // The comment is --help's text too, where <scene> reads as it should.
    #[allow(rustdoc::invalid_html_tags)]
    #[arg(short = 'f', long = "output", value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Resolution in pixels
    // `Set`, as for every single-value flag: given twice is an error (a
    // list flag appends by default, and the first pair was used silently).
    #[arg(short = 'r', long = "resolution", num_args = 2, value_names = ["W", "H"],
          action = clap::ArgAction::Set,
          default_values_t = [800u32, 600],
          value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub resolution: Vec<u32>,

    /// Adaptive sampling: test convergence every SAMPLES_PER_BATCH samples; a pixel stops
    /// when its 95% confidence interval is within TOLERANCE of its mean
    #[arg(short = 'a', long = "adaptive", num_args = 2, action = clap::ArgAction::Set,
          value_names = ["SAMPLES_PER_BATCH", "TOLERANCE"], default_values = ["32", "0.05"],
          allow_negative_numbers = true, conflicts_with = "no_adaptive")]
    pub adaptive: Vec<String>,

    /// Take exactly --spp samples in every pixel (no adaptive sampling)
    #[arg(long = "no-adaptive")]
    pub no_adaptive: bool,

    /// Direct lighting by uniform hemisphere sampling instead of light sampling
    #[arg(short = 'H', long = "hemisphere")]
    pub hemisphere: bool,

    /// Which bounces of light reach the image
    #[arg(long = "bounces", value_enum, default_value_t = Bounces::Accumulate)]
    pub bounces: Bounces,

    /// Turn Russian roulette off (the mean is the same; no difference up to -m 6 with the default --roulette-depth)
    #[arg(long = "no-roulette")]
    pub no_roulette: bool,

    /// First path vertex (0 = the camera ray's hit) at which Russian roulette may end a path; 1 trades error for speed per sample
    #[arg(long = "roulette-depth", value_name = "N", default_value_t = crate::integrator::ROULETTE_DEPTH,
          conflicts_with = "no_roulette")]
    pub roulette_depth: u32,

    /// Camera settings file written by the CS184 viewer: its position, orientation, clip planes and vertical field of view replace the scene's camera (the lens stays with -b and -d)
    #[arg(short = 'c', long = "camera", value_name = "FILE")]
    pub camera: Option<PathBuf>,

    /// Render only the cell of columns X..X+DX and rows Y..Y+DY (counted from the bottom, as in the CS184 renderer) and write it as a DX×DY image
    #[arg(short = 'p', long = "region", num_args = 4, value_names = ["X", "Y", "DX", "DY"],
          action = clap::ArgAction::Set)]
    pub region: Option<Vec<u32>>,

    /// Environment map: a latitude–longitude image (OpenEXR .exr or Radiance .hdr) lighting the scene from every direction (row 0 looks up, +y; the middle column along +x), seen by camera rays
    #[arg(short = 'e', long = "envmap", value_name = "FILE")]
    pub envmap: Option<PathBuf>,

    /// Thin-lens aperture radius (0 = pinhole)
    // Negative numbers reach `validate`, whose message names the flag and
    // the rule (clap would call `-1` an unknown flag).
    #[arg(
        short = 'b',
        long = "lens-radius",
        value_name = "R",
        allow_negative_numbers = true,
        default_value_t = 0.0
    )]
    pub lens_radius: f32,

    /// Thin-lens focal distance
    #[arg(
        short = 'd',
        long = "focal-distance",
        value_name = "D",
        allow_negative_numbers = true,
        default_value_t = 4.7
    )]
    pub focal_distance: f32,

    /// Random seed: the same seed gives the same image on any thread count
    #[arg(long = "seed", default_value_t = 0)]
    pub seed: u32,

    /// What to render
    #[arg(long = "shading", value_enum, default_value_t = View::Path)]
    pub shading: View,

    /// Acceleration structure
    #[arg(long = "accel", default_value_t = Accel::Sah)]
    pub accel: Accel,

    /// PNG tone curve: the CS184 renderer's, or sRGB
    #[arg(long = "tonemap", value_enum, default_value_t = ToneCurve::Reference)]
    pub tonemap: ToneCurve,

    /// Paths per wave
    #[arg(long = "batch-size", value_name = "N", default_value_t = 4096,
          value_parser = clap::value_parser!(u32).range(1..=1_048_576))]
    pub batch_size: u32,

    /// No progress (a bar on a terminal, else a line every 10 s) or closing report (warnings and errors still go to stderr)
    #[arg(short = 'q', long = "quiet")]
    pub quiet: bool,

    /// Print per-stage ray counts and time shares, and BVH statistics
    #[arg(long = "stats")]
    pub stats: bool,
}
