//! `wavepath compare <image> <reference>`: error metrics between two images.
//!
//! Why this exists: "is this render right, and how noisy is it?" needs a
//! number, not a squint. This prints RMSE, relMSE, MAPE and max error per
//! channel and overall (definitions in [`crate::film::metrics`]), a
//! statistical same-mean test when both files carry per-pixel standard
//! errors (EXRs from `wavepath converge --make-reference`), and with
//! `--diff` writes a false-colour map of the per-pixel relative error.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use clap::Parser;
use glam::Vec3;

use crate::film::Image;
use crate::film::metrics::{self, REL_EPSILON};
use crate::film::output::{self, Format, ToneCurve};

#[derive(Parser, Debug)]
#[command(
    name = "wavepath compare",
    bin_name = "wavepath compare",
    about = "Error metrics of an image against a reference (EXR or PNG)",
    after_help = "relMSE = mean (x - ref)^2 / (ref^2 + 0.01) over pixels and channels; \
                  MAPE = mean |x - ref| / (|ref| + 0.01), in percent.\n\
                  PNGs are decoded to linear values with the inverse of --tonemap.\n\
                  Example: wavepath compare render.exr reference.exr --diff err.png"
)]
pub struct CompareArgs {
    /// The image to judge (.exr or .png)
    pub image: PathBuf,
    /// The reference (.exr or .png), taken as the truth
    pub reference: PathBuf,
    /// Write a false-colour PNG of the per-pixel relative error
    #[arg(long = "diff", value_name = "PNG")]
    pub diff: Option<PathBuf>,
    /// Relative error shown as full red in --diff [default: the 99th percentile]
    #[arg(long = "diff-scale", value_name = "E", allow_negative_numbers = true)]
    pub diff_scale: Option<f32>,
    /// Curve PNG inputs were encoded with (wavepath writes `reference` unless told otherwise)
    #[arg(long = "tonemap", value_enum, default_value_t = ToneCurve::Reference)]
    pub tonemap: ToneCurve,
    /// Both images come from one estimator and settings (seeds and samples
    /// may differ): the same-mean test then takes each pixel's per-sample
    /// variance as the larger of the two files' estimates (both must record
    /// sample counts), so a pixel whose few samples saw no spread is not
    /// taken as certain
    #[arg(long = "same-estimator")]
    pub same_estimator: bool,
}

/// Below this many samples in a pixel, its own variance estimate is too
/// unreliable for the per-pixel test without `--same-estimator` (a pixel
/// beside an edge whose few samples all fell on one side looks certain).
const FEW_SAMPLES: u32 = 32;

/// Reads an input image with an error that names the file; PNGs are
/// decoded with the inverse of `curve`.
pub fn load(path: &Path, curve: ToneCurve) -> Result<Image> {
    if !path.exists() {
        bail!("{}: no such file", path.display());
    }
    Format::from_path(path).map_err(|_| {
        anyhow::anyhow!(
            "{}: unknown image format (expected a .exr or .png file)",
            path.display()
        )
    })?;
    output::read_image_with(path, curve)
}

/// Colour ramp for an error in [0, 1]: black → blue → green → yellow → red.
pub fn error_colour(t: f32) -> Vec3 {
    const STOPS: [Vec3; 5] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let s = t * (STOPS.len() - 1) as f32;
    let i = (s as usize).min(STOPS.len() - 2);
    STOPS[i].lerp(STOPS[i + 1], s - i as f32)
}

/// Writes the relative-error map as a PNG; returns the scale used.
pub fn write_diff(
    image: &Image,
    reference: &Image,
    path: &Path,
    scale: Option<f32>,
) -> Result<f32> {
    let errors = metrics::relative_error_map(image, reference)?;
    let scale = scale.unwrap_or_else(|| {
        let mut sorted: Vec<f32> = errors.iter().copied().filter(|e| e.is_finite()).collect();
        sorted.sort_by(f32::total_cmp);
        let p99 = sorted
            .get(((sorted.len() as f64 * 0.99) as usize).min(sorted.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0.0);
        if p99 > 0.0 { p99 } else { 1.0 }
    });
    let data: Vec<u8> = errors
        .iter()
        .flat_map(|&e| {
            let c = error_colour(e / scale);
            [c.x, c.y, c.z].map(|v| (255.0 * v).round() as u8)
        })
        .collect();
    output::save_rgb8(image.width, image.height, &data, path)?;
    Ok(scale)
}

/// Runs `wavepath compare`; `argv` starts with the subcommand's name.
pub fn run(argv: Vec<std::ffi::OsString>) -> Result<i32> {
    let args = CompareArgs::parse_from(argv);
    let fail = super::usage_error::<CompareArgs>;
    if let Some(s) = args.diff_scale
        && !(s > 0.0 && s.is_finite())
    {
        fail(format!("--diff-scale must be a positive number, got {s}"));
    }
    if let Some(d) = &args.diff {
        if Format::from_path(d).ok() != Some(Format::Png) {
            fail(format!(
                "--diff {}: writes a PNG; name a .png file",
                d.display()
            ));
        }
        if let Some(why) = super::unwritable(d) {
            fail(format!("--diff {}: {why}", d.display()));
        }
    }
    let image = load(&args.image, args.tonemap)?;
    let reference = load(&args.reference, args.tonemap)?;
    if (image.width, image.height) != (reference.width, reference.height) {
        bail!(
            "{} is {}x{} but the reference {} is {}x{}: sizes must match",
            args.image.display(),
            image.width,
            image.height,
            args.reference.display(),
            reference.width,
            reference.height
        );
    }
    for (im, path) in [(&image, &args.image), (&reference, &args.reference)] {
        let bad = im.non_finite_count();
        if bad > 0 {
            eprintln!(
                "warning: {}: {bad} pixels are NaN or infinite; metrics will be too",
                path.display()
            );
        }
    }
    let m = metrics::compare(&image, &reference)?;
    say!(
        "{} vs reference {} ({}x{})",
        args.image.display(),
        args.reference.display(),
        image.width,
        image.height
    );
    say!(
        "{:<8} {:>12} {:>12} {:>10} {:>12}",
        "channel",
        "RMSE",
        "relMSE",
        "MAPE %",
        "max error"
    );
    let names = ["R", "G", "B"];
    for (name, c) in names
        .iter()
        .copied()
        .zip(&m.channels)
        .chain(std::iter::once(("all", &m.overall)))
    {
        say!(
            "{name:<8} {:>12.4e} {:>12.4e} {:>10.3} {:>12.4e}",
            c.rmse,
            c.rel_mse,
            c.mape,
            c.max_error
        );
    }
    let has_error = |im: &Image| im.variance.iter().any(|v| *v != Vec3::ZERO);
    // Only an EXR's header can hold a reference's record.
    let note = match output::Format::from_path(&args.reference) {
        Ok(output::Format::Exr) => super::converge::reference_note(&args.reference)?,
        _ => None,
    };
    if let Some((noise, how)) = super::converge::reference_noise(note.as_ref(), &reference) {
        say!("reference noise: its own relMSE is about {noise:.3e} ({how})");
    }
    let files = [(&image, &args.image), (&reference, &args.reference)];
    let without_errors = files.into_iter().find(|(im, _)| !has_error(im));
    if let Some((_, path)) = without_errors.filter(|_| args.same_estimator) {
        eprintln!(
            "warning: --same-estimator: no same-mean test, as {} has no standard-error \
             channels (converge --make-reference writes them)",
            path.display()
        );
    }
    if without_errors.is_none() {
        let alpha = 1e-3;
        // The fewest samples a pixel holds, where the file records counts
        // (0: not recorded).
        let fewest = |im: &Image| im.samples.iter().copied().filter(|&n| n > 0).min();
        let uncounted: Vec<&PathBuf> = files
            .iter()
            .filter(|(im, _)| fewest(im).is_none())
            .map(|(_, path)| *path)
            .collect();
        if args.same_estimator {
            for path in &uncounted {
                eprintln!(
                    "warning: --same-estimator needs sample counts in both files, and {} \
                     has none: each file's own variance is used",
                    path.display()
                );
            }
        }
        // Each file's own variances are what the per-pixel test uses.
        let own_variances = !args.same_estimator || !uncounted.is_empty();
        for (im, path) in files {
            if let Some(n) = fewest(im).filter(|&n| own_variances && n < FEW_SAMPLES) {
                eprintln!(
                    "warning: {}: some pixels hold only {n} samples, too few to estimate their \
                     variance: the per-pixel test may call equal images different; for images \
                     of one estimator, --same-estimator takes the larger of the two files' \
                     estimates",
                    path.display()
                );
            }
        }
        let t = metrics::z_test(&image, &reference, alpha, args.same_estimator)?;
        say!(
            "same-mean test (alpha {alpha} each): max |z| {:.2} at ({}, {}, {}) vs Bonferroni {:.2}; \
             global z {:.2} vs {:.2}: {}",
            t.max_abs_z,
            t.worst.0,
            t.worst.1,
            names[t.worst.2],
            t.z_threshold,
            t.global_z,
            t.global_threshold,
            if t.passes() {
                "consistent"
            } else {
                "DIFFERENT"
            }
        );
    }
    if let Some(path) = &args.diff {
        let scale = write_diff(&image, &reference, path, args.diff_scale)?;
        say!(
            "wrote {}: per-pixel relative error |x - ref| / (|ref| + {REL_EPSILON}), mean of R, G, B; \
             black = 0, blue {:.3e}, green {:.3e}, yellow {:.3e}, red >= {:.3e}",
            path.display(),
            scale * 0.25,
            scale * 0.5,
            scale * 0.75,
            scale
        );
    }
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ramp_runs_black_blue_green_yellow_red_and_clamps() {
        let stops = [
            (0.0, Vec3::ZERO),
            (0.25, Vec3::Z),
            (0.5, Vec3::Y),
            (0.75, Vec3::new(1.0, 1.0, 0.0)),
            (1.0, Vec3::X),
        ];
        for (t, c) in stops {
            assert_eq!(error_colour(t), c, "{t}");
        }
        // Linear between stops.
        assert!((error_colour(0.125) - Vec3::new(0.0, 0.0, 0.5)).length() < 1e-6);
        assert!((error_colour(0.375) - Vec3::new(0.0, 0.5, 0.5)).length() < 1e-6);
        assert!((error_colour(0.625) - Vec3::new(0.5, 1.0, 0.0)).length() < 1e-6);
        assert!((error_colour(0.875) - Vec3::new(1.0, 0.5, 0.0)).length() < 1e-6);
        // Outside [0, 1], and errors that are not numbers: the ends.
        assert_eq!(error_colour(-3.0), Vec3::ZERO);
        assert_eq!(error_colour(7.0), Vec3::X);
        assert_eq!(error_colour(f32::NAN), Vec3::X);
        assert_eq!(error_colour(f32::INFINITY), Vec3::X);
    }

    /// The map's scale is the 99th percentile of the per-pixel errors (so
    /// one pixel in a hundred shows full red), or what `--diff-scale`
    /// says; each pixel is the ramp at error / scale, rounded to 8 bits.
    /// Identical images give scale 1 and a black map.
    #[test]
    fn the_diff_map_is_the_ramp_at_error_over_the_99th_percentile() {
        let (w, h) = (20, 10);
        let mut reference = Image::new(w, h);
        reference.pixels.fill(Vec3::ONE);
        let mut image = reference.clone();
        // Pixel i is off by i/200 of the reference, in one channel or all.
        for (i, p) in image.pixels.iter_mut().enumerate() {
            let e = i as f32 / 200.0;
            *p = if i % 2 == 0 {
                Vec3::splat(1.0 + e)
            } else {
                Vec3::new(1.0 + 3.0 * e, 1.0, 1.0)
            };
        }
        let errors = metrics::relative_error_map(&image, &reference).unwrap();
        let mut sorted = errors.clone();
        sorted.sort_by(f32::total_cmp);

        let dir = crate::cli::scratch_dir("diff-map");
        let path = dir.join("diff.png");
        let check = |scale: f32| {
            let png = image::open(&path).unwrap().to_rgb8();
            assert_eq!(png.dimensions(), (w, h));
            for (i, px) in png.pixels().enumerate() {
                let c = error_colour(errors[i] / scale);
                let want = [c.x, c.y, c.z].map(|v| (255.0 * v).round() as u8);
                assert_eq!(px.0, want, "pixel {i}, error {}", errors[i]);
            }
        };
        // 200 pixels: the 99th percentile is the second largest error.
        let scale = write_diff(&image, &reference, &path, None).unwrap();
        assert_eq!(scale, sorted[198]);
        assert!(scale < sorted[199] && scale > 0.0);
        check(scale);

        assert_eq!(
            write_diff(&image, &reference, &path, Some(0.5)).unwrap(),
            0.5
        );
        check(0.5);

        assert_eq!(
            write_diff(&reference, &reference, &path, None).unwrap(),
            1.0
        );
        let png = image::open(&path).unwrap().to_rgb8();
        assert!(png.pixels().all(|p| p.0 == [0, 0, 0]));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
