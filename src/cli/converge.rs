//! `wavepath converge`: error against a reference as the sample budget grows.
//!
//! Why this exists: "faster" for a Monte Carlo renderer means less error in
//! the same time, not more rays per second. This renders a scene at
//! 1, 2, 4, … samples per pixel with each chosen estimator, measures
//! relMSE and RMSE against a reference ([`crate::film::metrics`]), and
//! writes a CSV and a log–log error-vs-time plot, plus the interpolated
//! time to reach target errors. `--make-reference` renders that reference
//! as independent replicates whose spread measures its own relMSE
//! ([`crate::film::replicates`]), recorded in the EXR with per-pixel
//! standard-error channels, so every number can be read against the
//! reference's own noise floor.
//!
//! The render flags (`-m`, `-l`, `-r`, `--seed`, `-t`, …) are the main
//! command's [`Args`], flattened in; sampling is never adaptive here.

use std::ffi::OsString;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::parser::ValueSource;
use clap::{CommandFactory, FromArgMatches, Parser, ValueEnum};

use super::Args;
use super::memory;
use super::plot::{self, Curve};
use crate::bvh::Bvh;
use crate::film::output::{self, Format};
use crate::film::{Image, metrics, replicates};
use crate::integrator::{Settings, View};
use crate::wavefront::{RenderSettings, Renderer};

/// References are rendered with `--seed` plus this, so that a reference
/// and the convergence renders made with the same `--seed` use independent
/// random numbers (correlated samples would make the error look smaller).
pub const REFERENCE_SEED_OFFSET: u32 = 1_000_003;

/// Reference samples per pixel when `-s` is not given (`-s`'s default
/// here, as clap takes it: text).
pub const DEFAULT_REFERENCE_SPP: &str = "1024";

/// A way of estimating the image. Each maps to integrator settings; a new
/// estimator (BSDF sampling, MIS, …) is a new variant here and one arm in
/// [`Estimator::configure`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Estimator {
    /// Direct lighting by uniform hemisphere sampling (`-H`)
    Hemisphere,
    /// Direct lighting by sampling the lights (the default)
    Light,
}

impl Estimator {
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Hemisphere => "hemisphere",
            Estimator::Light => "light",
        }
    }

    /// Sets the estimator's choices in `settings`, leaving the rest.
    pub fn configure(self, settings: &mut Settings) {
        settings.hemisphere = match self {
            Estimator::Hemisphere => true,
            Estimator::Light => false,
        };
    }

    /// The estimator the render flags select.
    pub fn from_settings(settings: &Settings) -> Estimator {
        if settings.hemisphere {
            Estimator::Hemisphere
        } else {
            Estimator::Light
        }
    }
}

#[derive(Parser, Debug)]
#[command(
    name = "wavepath converge",
    bin_name = "wavepath converge",
    about = "Error against a reference as the sample budget grows, per estimator; \
             or render that reference (--make-reference)",
    after_help = "Examples:\n  \
        wavepath converge --make-reference -s 1024 -m 5 -r 480 360 --ref ref.exr scene.dae\n  \
        wavepath converge -m 5 -r 480 360 --ref ref.exr --estimators hemisphere,light \
        --max-spp 256 --csv conv.csv scene.dae\n\
        The render flags are those of `wavepath --help`, but for -f, -a, -p, \
        --no-adaptive, --tonemap and --stats, and --shading takes only path; -s is the \
        reference's spp, given only with --make-reference."
)]
pub struct ConvergeArgs {
    #[command(flatten)]
    pub render: Args,

    /// Reference EXR: read, or written with --make-reference
    #[arg(long = "ref", value_name = "EXR", required_unless_present = "plot_csv")]
    pub reference: Option<PathBuf>,

    /// Render nothing: plot relMSE against time from CSV files this command
    /// wrote (comma-separated; e.g. several scenes, or another renderer's
    /// numbers in the same columns) into --plot
    #[arg(long = "plot-csv", value_name = "CSV", value_delimiter = ',')]
    pub plot_csv: Vec<PathBuf>,

    /// Render the reference (-s spp as up to 8 replicates with seeds from
    /// --seed + 1000003, their spread measuring its own error) with
    /// per-pixel standard-error channels, and stop
    #[arg(long = "make-reference")]
    pub make_reference: bool,

    /// Largest budget in samples per pixel (budgets double from 1)
    #[arg(long = "max-spp", value_name = "N", default_value_t = 256,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub max_spp: u32,

    /// Stop doubling once a render takes at least this long (seconds);
    /// --max-spp still caps the budget when given
    #[arg(long = "seconds", value_name = "S", allow_negative_numbers = true)]
    pub seconds: Option<f64>,

    /// Estimators to compare, comma-separated [default: the one -H selects]
    #[arg(long = "estimators", value_enum, value_delimiter = ',')]
    pub estimators: Vec<Estimator>,

    /// relMSE targets to report the time to reach, comma-separated
    #[arg(
        long = "targets",
        value_delimiter = ',',
        default_value = "1e-2,1e-3",
        allow_negative_numbers = true
    )]
    pub targets: Vec<f64>,

    /// CSV output: estimator, spp, seconds, relMSE, RMSE, relMSE less the
    /// reference's noise, process CPU seconds
    #[arg(long = "csv", value_name = "FILE", default_value = "converge.csv")]
    pub csv: PathBuf,

    /// SVG plot of relMSE against time [default: the CSV's name with .svg]
    #[arg(long = "plot", value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

/// The text attribute of a reference EXR's header that records its
/// [`expectation`] and its own relMSE ([`OWN_REL_MSE`]), as `name=value`
/// pairs joined by `;` (one attribute, as the EXR writer orders several at
/// random, and the same reference should be the same bytes).
const REFERENCE_NOTE: &str = "wavepath.reference";

/// The pair of [`REFERENCE_NOTE`] that holds the reference's own relMSE,
/// measured from its replicates ([`crate::film::replicates`]).
const OWN_REL_MSE: &str = "own-relMSE";

/// A reference is rendered as this many independent replicates (fewer when
/// it has fewer samples per pixel), so that its own error can be measured.
pub const REFERENCE_REPLICATES: u32 = 8;

/// The `name=value` pairs of a reference's [`REFERENCE_NOTE`].
pub(crate) type Note = Vec<(String, String)>;

/// A reference's [`Note`]; `None` for an EXR that has none (not made by
/// `converge --make-reference`).
pub(crate) fn reference_note(path: &Path) -> Result<Option<Note>> {
    let notes = output::read_exr_notes(path)?;
    Ok(notes
        .into_iter()
        .find(|(name, _)| name == REFERENCE_NOTE)
        .map(|(_, text)| {
            text.split(';')
                .filter_map(|pair| pair.split_once('='))
                .map(|(n, v)| (n.to_string(), v.to_string()))
                .collect()
        }))
}

/// A reference's own relMSE and where it comes from: the figure its
/// replicates measured, where its `note` records one, else the one its
/// per-pixel standard errors give (an overestimate for stratified
/// samples), else `None`.
pub(crate) fn reference_noise(note: Option<&Note>, reference: &Image) -> Option<(f64, String)> {
    let recorded = note
        .and_then(|pairs| pairs.iter().find(|(n, _)| n == OWN_REL_MSE))
        .and_then(|(_, v)| v.parse::<f64>().ok())
        .filter(|v| (0.0..f64::INFINITY).contains(v));
    if let Some(v) = recorded {
        return Some((v, "measured from its independent replicates".into()));
    }
    if reference.variance.iter().all(|v| *v == glam::Vec3::ZERO) {
        return None;
    }
    Some((
        metrics::rel_mse_from_variance(reference),
        "from its standard-error channels, s²/n per pixel: for stratified samples usually \
         an overestimate"
            .into(),
    ))
}

/// Reads the reference for renders with `settings`: of their size, and
/// with finite pixels.
fn load_reference(path: &Path, settings: &RenderSettings) -> Result<Image> {
    let reference = super::compare::load(path, output::ToneCurve::Reference)?;
    if (reference.width, reference.height) != (settings.width, settings.height) {
        bail!(
            "{} is {}x{} but the renders are {}x{} (give -r {} {})",
            path.display(),
            reference.width,
            reference.height,
            settings.width,
            settings.height,
            reference.width,
            reference.height
        );
    }
    let bad = reference.non_finite_count();
    if bad > 0 {
        bail!(
            "{}: {bad} pixels are NaN or infinite; every error against it would be NaN",
            path.display()
        );
    }
    Ok(reference)
}

/// The fingerprint of the scene file's bytes (or the built-in scene's).
fn scene_file_digest(args: &Args) -> Result<u64> {
    Ok(match &args.scene {
        Some(path) => digest(
            &std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?,
        ),
        None => digest(super::DEFAULT_SCENE.as_bytes()),
    })
}

/// What decides the expected value of a render's pixels, besides its size
/// (checked on its own): the scene file (`scene_digest`), the camera as
/// loaded (the scene's, or a `-c` file's), the depth, which bounces count,
/// the lens, and whether the point and directional lights are found
/// (`-H` misses them). The seed, `-l` and roulette change only the noise,
/// and so does the estimator where the scene has no such lights, so a
/// reference may differ in those. Each entry is (setting, value);
/// `--make-reference` records them in the EXR ([`REFERENCE_NOTE`]), and
/// a reference that recorded other values is refused: error measured
/// against another image means nothing.
fn expectation(
    scene_digest: u64,
    settings: &RenderSettings,
    scene: &crate::scene::Scene,
) -> Vec<(&'static str, String)> {
    let s = &settings.integrator;
    // -0 and 0 are the same lens.
    let lens_radius = if settings.lens_radius == 0.0 {
        0.0
    } else {
        settings.lens_radius
    };
    let mut expected = vec![
        ("scene", format!("{scene_digest:016x}")),
        (
            "camera",
            format!("{:016x}", digest(format!("{:?}", scene.camera).as_bytes())),
        ),
        ("-m", s.max_depth.to_string()),
        ("--bounces", clap_name(&s.bounces)),
        ("-b", lens_radius.to_string()),
    ];
    // Without a lens every distance is in focus.
    if lens_radius > 0.0 {
        expected.push(("-d", settings.focal_distance.to_string()));
    }
    let (found, missed) = s.delta_lights(&scene.lights);
    if found + missed > 0 {
        let seen = if missed > 0 { "missed" } else { "found" };
        expected.push(("point and directional lights", seen.into()));
    }
    expected
}

/// A flag value's name as given on the command line.
fn clap_name(value: &impl ValueEnum) -> String {
    value
        .to_possible_value()
        .map_or_else(|| "?".into(), |v| v.get_name().to_string())
}

/// 64-bit FNV-1a: a file's fingerprint, to tell two versions apart.
fn digest(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Refuses a reference (at `path`, with `note`) that records another
/// [`expectation`] than one of `ours` (one per estimator measured). One
/// that records none (from another program) is taken on trust, with a
/// warning.
fn check_expectation(path: &Path, note: Option<&Note>, ours: &[Vec<(&str, String)>]) -> Result<()> {
    let Some(theirs) = note else {
        eprintln!(
            "warning: {} records no settings (it was not made by converge --make-reference): \
             taken on trust to show the image these renders estimate",
            path.display()
        );
        return Ok(());
    };
    for ours in ours {
        check_pairs(path, theirs, ours)?;
    }
    Ok(())
}

/// [`check_expectation`] for one estimator's pairs.
fn check_pairs(path: &Path, theirs: &[(String, String)], ours: &[(&str, String)]) -> Result<()> {
    let differences: Vec<String> = ours
        .iter()
        .filter_map(|(name, value)| {
            let (_, theirs) = theirs.iter().find(|(n, _)| n == name)?;
            (theirs != value).then(|| match (*name, theirs.as_str()) {
                ("scene", _) => "another scene file, or another version of it".to_string(),
                ("camera", _) => "another camera".to_string(),
                ("point and directional lights", "missed") => {
                    "without the point and directional lights' light (made with -H)".to_string()
                }
                ("point and directional lights", _) => {
                    "with the point and directional lights' light, which -H leaves out here"
                        .to_string()
                }
                _ => format!("{name} {theirs} where these renders use {name} {value}"),
            })
        })
        .collect();
    if !differences.is_empty() {
        bail!(
            "{}: the reference shows another image than these renders ({}); make one for \
             them with --make-reference",
            path.display(),
            differences.join("; ")
        );
    }
    Ok(())
}

/// Warns of the light that `estimator` with `settings` can never find
/// ([`Settings::blind_spots`]).
fn warn_blind_spots(estimator: Estimator, settings: &Settings, lights: &[crate::scene::Light]) {
    let mut s = *settings;
    estimator.configure(&mut s);
    for note in s.blind_spots(lights) {
        eprintln!("warning: {} estimator: {note}", estimator.name());
    }
}

/// CPU time (user + system) this process has used, in seconds, where the
/// OS reports it (Linux `/proc/self/stat`, at its 100 Hz tick). On a
/// machine shared with other work, CPU time / threads is what a render
/// would take on idle cores, while wall time depends on the neighbours.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the
    // 14th and 15th fields of the whole line.
    let rest = &stat[stat.rfind(')')? + 2..];
    let mut fields = rest.split_whitespace().skip(11);
    let utime: f64 = fields.next()?.parse().ok()?;
    let stime: f64 = fields.next()?.parse().ok()?;
    const TICKS_PER_SECOND: f64 = 100.0;
    Some((utime + stime) / TICKS_PER_SECOND)
}

/// One measured budget.
#[derive(Clone, Debug)]
pub struct Row {
    pub estimator: Estimator,
    pub spp: u32,
    /// Wall-clock render time.
    pub seconds: f64,
    /// Process CPU time of the render (all threads), if known.
    pub cpu_seconds: Option<f64>,
    pub rel_mse: f64,
    pub rmse: f64,
}

/// Time at which the measured (time, error) curve first reaches `target`,
/// interpolated linearly in log–log between the budgets around it.
/// `Some((t, false))` when reached between budgets, `Some((t0, true))` when
/// already the first budget was below (t is an upper bound), `None` when
/// never reached.
pub fn time_to_reach(points: &[(f64, f64)], target: f64) -> Option<(f64, bool)> {
    let i = points.iter().position(|&(_, e)| e <= target)?;
    if i == 0 {
        return Some((points[0].0, true));
    }
    let ((t0, e0), (t1, e1)) = (points[i - 1], points[i]);
    if !(e0 > e1 && t0 > 0.0 && t1 > 0.0 && e1 > 0.0) {
        return Some((t1, false));
    }
    let f = (e0.ln() - target.ln()) / (e0.ln() - e1.ln());
    Some(((t0.ln() + f * (t1.ln() - t0.ln())).exp(), false))
}

/// Render flags that mean nothing here (the id of each in [`Args`], and
/// why): given, they are refused rather than ignored, and `--help` does
/// not list them.
const NOT_USED: [(&str, &str); 6] = [
    (
        "output",
        "converge: -f is not used; name the reference with --ref, outputs with --csv and --plot",
    ),
    (
        "adaptive",
        "converge: -a is not used; every budget is a fixed number of samples per pixel",
    ),
    (
        "region",
        "converge: -p is not used; it measures whole images, not a cell",
    ),
    (
        "tonemap",
        "converge: --tonemap is not used; it writes no PNG",
    ),
    (
        "stats",
        "converge: --stats is not used; see `wavepath --stats` for a render's statistics",
    ),
    (
        "no_adaptive",
        "converge: --no-adaptive is not needed; sampling is never adaptive here",
    ),
];

/// The command line of `wavepath converge`: the render flags, less those
/// in [`NOT_USED`], with `-s` as the reference's samples per pixel.
fn command() -> clap::Command {
    let mut command = ConvergeArgs::command().mut_arg("spp", |a| {
        a.default_value(DEFAULT_REFERENCE_SPP)
            .help("Samples per pixel of the reference (--make-reference)")
    });
    for (id, _) in NOT_USED {
        command = command.mut_arg(id, |a| a.hide(true));
    }
    command
}

/// Exits on a bad flag value of `wavepath converge`, as clap does: the
/// message, the usage line of converge's own [`command`], status 2.
fn fail(msg: String) -> ! {
    super::exit_with_usage(command(), msg)
}

/// Runs `wavepath converge`; `argv` starts with the subcommand's name.
pub fn run(argv: Vec<OsString>) -> Result<i32> {
    let matches = command().get_matches_from(argv);
    let args = ConvergeArgs::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let from_command_line = |id: &str| matches.value_source(id) == Some(ValueSource::CommandLine);
    if let Some((_, why)) = NOT_USED.iter().find(|(id, _)| from_command_line(id)) {
        fail(why.to_string());
    }
    if args.make_reference && args.render.spp < 2 {
        fail(format!(
            "--make-reference -s {}: a reference takes at least 2 samples per pixel (one \
             sample has no spread to measure its error by)",
            args.render.spp
        ));
    }
    if from_command_line("spp") && !args.make_reference {
        fail(
            "converge: -s sets the reference's samples per pixel, with --make-reference; \
             the budgets measured are 1, 2, 4, … up to --max-spp"
                .into(),
        );
    }
    if args.render.shading != View::Path {
        fail(format!(
            "--shading {}: converge measures the light-transport estimators (--shading path) \
             against a path-traced reference",
            clap_name(&args.render.shading)
        ));
    }
    if let Some(plot) = &args.plot
        && !plot
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("svg"))
    {
        fail(format!(
            "--plot {}: the plot is written as SVG; give a .svg file name",
            plot.display()
        ));
    }
    if !args.plot_csv.is_empty() {
        return plot_csv_files(&args);
    }
    let Some(reference_path) = args.reference.clone() else {
        fail("converge: --ref is required".into());
    };
    if Format::from_path(&reference_path).ok() != Some(Format::Exr) {
        fail(format!(
            "--ref {}: the reference must be an .exr file",
            reference_path.display()
        ));
    }
    if let Some(s) = args.seconds
        && !(s > 0.0 && s.is_finite())
    {
        fail(format!("--seconds must be a positive number, got {s}"));
    }
    if let Some(t) = args.targets.iter().find(|t| !(**t > 0.0 && t.is_finite())) {
        fail(format!("--targets must be positive numbers, got {t}"));
    }

    let (mut settings, _, _) = super::validate(&args.render, fail);
    settings.adaptive = None;
    // Every render here estimates each pixel's average, as the reference
    // does: the 1-spp budget too takes a random point of the pixel, not
    // its centre (which would measure another image's error).
    settings.centre_single_sample = false;
    let estimators = match (args.make_reference, args.estimators.as_slice()) {
        (true, [_, _, ..]) => {
            fail("--make-reference renders one estimator; give at most one in --estimators".into())
        }
        (_, []) => vec![Estimator::from_settings(&settings.integrator)],
        (_, chosen) => chosen.to_vec(),
    };
    // Two images at once: a reference's replicate and the replicates'
    // running sums, or the reference and a render measured against it
    // (the reference is read from its file's decoded channels, which take
    // an image's room again until it is read).
    let (per_pixel, what) = if args.make_reference {
        (
            Image::BYTES_PER_PIXEL + replicates::BYTES_PER_PIXEL,
            "a replicate and the replicates' running sums",
        )
    } else {
        (2 * Image::BYTES_PER_PIXEL, "the reference and a render")
    };
    if let Some(why) =
        memory::converge_does_not_fit(settings.area().pixel_count() as u64, per_pixel, what)
    {
        fail(format!("-r {} {}: {why}", settings.width, settings.height));
    }
    let plot_path = args
        .plot
        .clone()
        .unwrap_or_else(|| args.csv.with_extension("svg"));
    let outputs = if args.make_reference {
        vec![("--ref", &reference_path)]
    } else {
        vec![("--csv", &args.csv), ("--plot", &plot_path)]
    };
    for (flag, path) in outputs {
        if let Some(why) = super::unwritable(path) {
            fail(format!("{flag} {}: {why}", path.display()));
        }
    }
    let chatty = !args.render.quiet;

    let (pool, threads) = super::thread_pool(&args.render)?;
    let scene = super::load_scene(&args.render)?;
    let scene_name = super::scene_path(&args.render).display().to_string();
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    for &estimator in &estimators {
        warn_blind_spots(estimator, &settings.integrator, &scene.lights);
    }
    let scene_digest = scene_file_digest(&args.render)?;
    let base = settings;
    let expected = |estimator: Estimator| {
        let mut s = base;
        estimator.configure(&mut s.integrator);
        expectation(scene_digest, &s, &scene)
    };

    // The reference is read and checked before the BVH is built.
    let reference = if args.make_reference {
        None
    } else {
        let reference = load_reference(&reference_path, &settings)?;
        let note = reference_note(&reference_path)?;
        let ours: Vec<_> = estimators.iter().map(|&e| expected(e)).collect();
        check_expectation(&reference_path, note.as_ref(), &ours)?;
        Some((reference, note))
    };

    let bvh = pool.install(|| Bvh::build(&scene.geometry, args.render.accel));
    let renderer = Renderer::new(&scene, &bvh);
    for w in &renderer.warnings {
        eprintln!("warning: {w}");
    }

    let cancel = super::cancel_on_ctrl_c();
    let render = |s: &RenderSettings| {
        let cpu = process_cpu_seconds();
        let t = Instant::now();
        let out = pool.install(|| renderer.render(s, &|_| {}, &cancel));
        let wall = t.elapsed().as_secs_f64();
        let cpu = cpu.zip(process_cpu_seconds()).map(|(a, b)| b - a);
        (out, wall, cpu)
    };

    let Some((reference, note)) = reference else {
        let estimator = estimators[0];
        estimator.configure(&mut settings.integrator);
        settings.seed = settings.seed.wrapping_add(REFERENCE_SEED_OFFSET);
        // Independent replicates, each with its own seeds (spaced so that
        // references made with neighbouring --seed values share none), of
        // equal samples: -s rounded up to a multiple of their number.
        let parts = args.render.spp.min(REFERENCE_REPLICATES);
        settings.spp = args.render.spp.div_ceil(parts);
        if chatty {
            eprintln!(
                "rendering the reference: {scene_name}, {}x{}, {} spp ({parts} replicates of {}), \
                 -m {}, {} estimator, {threads} threads",
                settings.width,
                settings.height,
                parts * settings.spp,
                settings.spp,
                settings.integrator.max_depth,
                estimator.name()
            );
        }
        let seed = settings.seed;
        let area = settings.area();
        let mut replicates = replicates::Replicates::new(area.width, area.height);
        let mut secs = 0.0;
        for k in 0..parts {
            settings.seed = seed.wrapping_add(k.wrapping_mul(0x9e37_79b9));
            let (out, s, _) = render(&settings);
            secs += s;
            if !out.complete {
                break;
            }
            replicates.add(&out.image);
            if chatty {
                eprintln!("replicate {} of {parts} done in {s:.1} s", k + 1);
            }
        }
        // Ctrl-C: the replicates finished make a reference of fewer
        // samples, as good as one asked for with a smaller -s, when there
        // are two to measure its spread by.
        let done = replicates.count();
        let interrupted = done < parts;
        if interrupted && done < 2 {
            eprintln!(
                "interrupted: no reference written ({done} of {parts} replicates finished; a \
                 reference takes two)"
            );
            return Ok(super::EXIT_INTERRUPTED);
        }
        let combined = replicates.combine();
        let bad = combined.image.non_finite_count();
        if bad > 0 {
            bail!(
                "the reference has {bad} NaN or infinite pixels (radiance beyond f32's range?); \
                 not written to {}",
                reference_path.display()
            );
        }
        let mut pairs: Vec<String> = expected(estimator)
            .iter()
            .map(|(n, v)| format!("{n}={v}"))
            .collect();
        // -s 2 at least, so two replicates at least (or an interrupted
        // reference of two finished): a spread to measure.
        let own = combined
            .rel_mse
            .expect("a reference has two replicates or more");
        pairs.push(format!("{OWN_REL_MSE}={own:.6e}"));
        let note = (REFERENCE_NOTE.to_string(), pairs.join(";"));
        output::write_exr_with_error(&combined.image, &reference_path, &[note])?;
        say!(
            "wrote {} ({} spp in {secs:.1} s); its own relMSE, measured from {done} \
             independent replicates: {own:.3e}",
            reference_path.display(),
            done * settings.spp
        );
        if interrupted {
            eprintln!("interrupted: the reference holds the {done} of {parts} replicates finished");
            return Ok(super::EXIT_INTERRUPTED);
        }
        return Ok(0);
    };

    let floor = match reference_noise(note.as_ref(), &reference) {
        Some((floor, how)) => {
            say!(
                "reference {}: own relMSE about {floor:.3e}, {how} (measured relMSE = true relMSE + this, in expectation)",
                reference_path.display()
            );
            floor
        }
        None => {
            eprintln!(
                "warning: {} has no standard-error channels: its own noise is unknown and not subtracted",
                reference_path.display()
            );
            0.0
        }
    };

    // With --seconds and no explicit --max-spp, time alone stops the doubling.
    let max_spp = if args.seconds.is_some() && !from_command_line("max_spp") {
        u32::MAX / 2
    } else {
        args.max_spp
    };

    say!(
        "{scene_name}: {}x{}, -m {}, -l {}, seed {}, {threads} threads",
        settings.width,
        settings.height,
        settings.integrator.max_depth,
        settings.integrator.light_samples,
        settings.seed
    );
    say!(
        "{:<12} {:>7} {:>10} {:>10} {:>12} {:>12} {:>14}",
        "estimator",
        "spp",
        "seconds",
        "cpu s",
        "relMSE",
        "RMSE",
        "relMSE-floor"
    );
    let mut rows: Vec<Row> = Vec::new();
    let mut interrupted = false;
    'estimators: for &estimator in &estimators {
        let mut s = settings;
        estimator.configure(&mut s.integrator);
        let mut spp = 1u32;
        while spp <= max_spp {
            s.spp = spp;
            let (out, seconds, cpu_seconds) = render(&s);
            if !out.complete {
                interrupted = true;
                break 'estimators;
            }
            let m = metrics::compare(&out.image, &reference)?;
            let row = Row {
                estimator,
                spp,
                seconds,
                cpu_seconds,
                rel_mse: m.overall.rel_mse,
                rmse: m.overall.rmse,
            };
            say!(
                "{:<12} {:>7} {:>10.3} {:>10} {:>12.4e} {:>12.4e} {:>14.4e}",
                estimator.name(),
                spp,
                seconds,
                cpu_seconds.map_or("-".into(), |c| format!("{c:.2}")),
                row.rel_mse,
                row.rmse,
                row.rel_mse - floor
            );
            rows.push(row);
            if args.seconds.is_some_and(|limit| seconds >= limit) {
                break;
            }
            spp = spp.saturating_mul(2);
        }
    }

    let mut csv = String::from(
        "estimator,spp,seconds,rel_mse,rmse,rel_mse_minus_reference_noise,cpu_seconds\n",
    );
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{:.6},{:.6e},{:.6e},{:.6e},{}",
            r.estimator.name(),
            r.spp,
            r.seconds,
            r.rel_mse,
            r.rmse,
            r.rel_mse - floor,
            r.cpu_seconds.map_or(String::new(), |c| format!("{c:.2}"))
        );
    }
    std::fs::write(&args.csv, csv)
        .with_context(|| format!("{}: cannot write CSV", args.csv.display()))?;
    say!("wrote {}", args.csv.display());

    let curves: Vec<Curve> = estimators
        .iter()
        .map(|&e| Curve {
            name: e.name().to_string(),
            points: rows
                .iter()
                .filter(|r| r.estimator == e)
                .map(|r| (r.seconds, r.rel_mse))
                .collect(),
        })
        .filter(|c| !c.points.is_empty())
        .collect();
    if curves.is_empty() {
        // Interrupted before the first budget: nothing measured.
    } else if !plot::has_plottable_point(&curves) {
        eprintln!(
            "warning: {} not written: no budget has a positive error and time to plot (an \
             error of 0: the renders equal the reference)",
            plot_path.display()
        );
    } else {
        let title = format!(
            "{} {}x{} -m {}: relMSE vs time, {threads} threads",
            Path::new(&scene_name)
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("scene"),
            settings.width,
            settings.height,
            settings.integrator.max_depth
        );
        let floor_line = (floor > 0.0).then_some((floor, "reference noise"));
        plot::error_vs_time(&plot_path, &title, "relMSE", &curves, floor_line)?;
        say!("wrote {}", plot_path.display());
    }

    for c in &curves {
        let corrected: Vec<(f64, f64)> = c.points.iter().map(|&(t, e)| (t, e - floor)).collect();
        // CPU time / threads: the render time on idle cores (perfect scaling).
        let idle: Option<Vec<(f64, f64)>> = rows
            .iter()
            .filter(|r| r.estimator.name() == c.name)
            .map(|r| {
                r.cpu_seconds
                    .map(|cpu| (cpu / threads as f64, r.rel_mse - floor))
            })
            .collect();
        for &target in &args.targets {
            let describe = |r: Option<(f64, bool)>| match r {
                Some((t, false)) => format!("{t:.3} s"),
                Some((t, true)) => format!("<= {t:.3} s (first budget)"),
                None => "not reached".to_string(),
            };
            say!(
                "{}: time to relMSE <= {target:.0e}: {} (measured), {} (less the reference's noise)",
                c.name,
                describe(time_to_reach(&c.points, target)),
                describe(time_to_reach(&corrected, target))
            );
            if let Some(idle) = &idle {
                say!(
                    "{}: time to relMSE <= {target:.0e} from CPU time / {threads} threads: {} (less the reference's noise)",
                    c.name,
                    describe(time_to_reach(idle, target))
                );
            }
        }
    }
    if interrupted {
        eprintln!("interrupted: wrote the budgets finished so far");
        return Ok(super::EXIT_INTERRUPTED);
    }
    Ok(0)
}

/// `--plot-csv`: one curve per (file, estimator) of relMSE against wall time.
fn plot_csv_files(args: &ConvergeArgs) -> Result<i32> {
    let Some(plot_path) = &args.plot else {
        fail("--plot-csv needs --plot <FILE.svg>".into());
    };
    let mut curves: Vec<Curve> = Vec::new();
    for path in &args.plot_csv {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read CSV", path.display()))?;
        let mut lines = text.lines().enumerate();
        let header: Vec<&str> = lines
            .next()
            .map(|(_, l)| l.split(',').map(str::trim).collect())
            .unwrap_or_default();
        let column = |name: &str| {
            header
                .iter()
                .position(|h| *h == name)
                .with_context(|| format!("{}: no '{name}' column in the header", path.display()))
        };
        let (ce, ct, cr) = (column("estimator")?, column("seconds")?, column("rel_mse")?);
        let stem = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("csv")
            .to_string();
        for (i, line) in lines {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            let number = |c: usize| -> Result<f64> {
                f.get(c)
                    .and_then(|v| v.parse::<f64>().ok())
                    .with_context(|| {
                        format!(
                            "{}:{}: not a number in column {}",
                            path.display(),
                            i + 1,
                            c + 1
                        )
                    })
            };
            let name = format!("{stem} {}", f.get(ce).copied().unwrap_or(""));
            let point = (number(ct)?, number(cr)?);
            match curves.iter_mut().find(|c| c.name == name) {
                Some(c) => c.points.push(point),
                None => curves.push(Curve {
                    name,
                    points: vec![point],
                }),
            }
        }
    }
    plot::error_vs_time(plot_path, "relMSE vs render time", "relMSE", &curves, None)?;
    say!("wrote {}", plot_path.display());
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A recorded own relMSE is used when it is a number a relMSE can be;
    /// otherwise the per-pixel standard errors speak, or nothing does.
    #[test]
    fn a_references_noise_comes_from_its_record_if_sound() {
        let dir = crate::cli::scratch_dir("reference-noise");
        let mut image = Image::new(2, 1);
        image.pixels = vec![glam::Vec3::ONE; 2];
        let path = dir.join("ref.exr");
        let mut noise = |record: Option<&str>, variance: f32| {
            image.variance = vec![glam::Vec3::splat(variance); 2];
            let notes: Vec<(String, String)> = record
                .map(|r| {
                    (
                        REFERENCE_NOTE.to_string(),
                        format!("-m=1;{OWN_REL_MSE}={r}"),
                    )
                })
                .into_iter()
                .collect();
            output::write_exr_with_error(&image, &path, &notes).unwrap();
            let read = output::read_image(&path).unwrap();
            reference_noise(reference_note(&path).unwrap().as_ref(), &read)
        };
        let from_record = noise(Some("2.5e-4"), 0.0).unwrap();
        assert_eq!(from_record.0, 2.5e-4);
        assert!(from_record.1.contains("replicates"), "{from_record:?}");
        for unsound in ["nan", "-1e-4", "inf", "x"] {
            let (v, how) = noise(Some(unsound), 0.01).unwrap();
            assert!(how.contains("standard-error channels"), "{unsound}: {how}");
            assert!((v - 0.01 / 1.01).abs() < 1e-6, "{unsound}: {v}");
        }
        assert_eq!(noise(None, 0.0), None);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn time_to_reach_interpolates_in_log_log() {
        // Error ∝ 1/t: 1e-1 at 1 s, 1e-3 at 100 s → 1e-2 at 10 s.
        let pts = [(1.0, 1e-1), (100.0, 1e-3)];
        let (t, bound) = time_to_reach(&pts, 1e-2).unwrap();
        assert!((t - 10.0).abs() < 1e-9 && !bound);
        assert_eq!(time_to_reach(&pts, 1.0), Some((1.0, true)));
        assert_eq!(time_to_reach(&pts, 1e-4), None);
        // The same line shifted to start at 2 s: 1e-2 at 20 s.
        let pts = [(2.0, 1e-1), (200.0, 1e-3)];
        let (t, _) = time_to_reach(&pts, 1e-2).unwrap();
        assert!((t - 20.0).abs() < 1e-9, "{t}");
    }

    /// Where a logarithm would be of zero (a budget at 0 s, an error of
    /// exactly 0) or the errors are not numbers, the budget that reached
    /// the target is the answer, not an interpolation through −∞ or NaN.
    #[test]
    fn time_to_reach_takes_the_budget_where_log_log_cannot_interpolate() {
        for pts in [
            [(0.0, 1e-1), (4.0, 1e-3)],
            [(1.0, 1e-1), (0.0, 1e-3)],
            [(1.0, 1e-1), (4.0, 0.0)],
            [(1.0, f64::NAN), (4.0, 1e-3)],
        ] {
            let got = time_to_reach(&pts, 1e-2);
            assert_eq!(got, Some((pts[1].0, false)), "{pts:?}");
        }
    }
}
