//! The `wavepath` command: parse flags, load, build, render, write.
//!
//! `wavepath compare …`, `wavepath converge …` and `wavepath mitsuba …`
//! are dispatched on the first argument before the render flags are
//! parsed, so that `wavepath [options] <scene.dae>` is unchanged (a scene
//! file literally named `compare` is given as `./compare`).

/// `println!` for the reports on stdout, which does not panic when stdout
/// is closed early (`wavepath compare a.exr b.exr | head -1`): see
/// [`say_line`].
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::cli::say_line(format_args!($($arg)*))
    };
}

mod args;
pub mod compare;
pub mod converge;
mod memory;
pub mod mitsuba;
mod plot;
mod report;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{CommandFactory, Parser};
use indicatif::{ProgressBar, ProgressStyle};

pub use args::Args;

use crate::bvh::Bvh;
use crate::film::adaptive::Adaptive;
use crate::film::{Tile, output};
use crate::integrator::{Settings, View};
use crate::scene::{EnvironmentMap, Light, camera_file, collada};
use crate::wavefront::{RenderSettings, Renderer};

/// The scene rendered when none is named: `scenes/cornell.dae`, built in.
const DEFAULT_SCENE: &str = include_str!("../../scenes/cornell.dae");
const DEFAULT_SCENE_NAME: &str = "cornell.dae";

/// Exit status after Ctrl-C (128 + SIGINT), as shells expect.
pub const EXIT_INTERRUPTED: i32 = 130;

/// The scene's path, or the built-in scene's name.
fn scene_path(args: &Args) -> &std::path::Path {
    args.scene
        .as_deref()
        .unwrap_or(std::path::Path::new(DEFAULT_SCENE_NAME))
}

/// Exits as clap does on a bad flag value of command `C`: `msg`, the
/// command's usage line, status 2. Every command refuses its flags so;
/// status 1 is for the files it reads.
fn usage_error<C: CommandFactory>(msg: String) -> ! {
    exit_with_usage(C::command(), msg)
}

/// [`usage_error`] for a command built by hand (converge's, whose flags
/// differ from its parser's defaults).
fn exit_with_usage(mut command: clap::Command, msg: String) -> ! {
    command
        .error(clap::error::ErrorKind::ValueValidation, msg)
        .exit()
}

/// Checks what clap cannot: cross-field and float-valued flags.
/// Exits through `fail` (the calling command's usage error) on nonsense,
/// like clap's own errors.
fn validate(args: &Args, fail: fn(String) -> !) -> (RenderSettings, PathBuf, output::Format) {
    let adaptive = if args.no_adaptive {
        None
    } else {
        let spb: u32 = args.adaptive[0].parse().unwrap_or_else(|_| {
            fail(format!(
                "-a: samples per batch must be a positive integer, got '{}'",
                args.adaptive[0]
            ))
        });
        let tol: f32 = args.adaptive[1].parse().unwrap_or_else(|_| {
            fail(format!(
                "-a: tolerance must be a number, got '{}'",
                args.adaptive[1]
            ))
        });
        if spb == 0 {
            fail("-a: samples per batch must be at least 1".into());
        }
        if !(tol >= 0.0 && tol.is_finite()) {
            fail(format!(
                "-a: tolerance must be a non-negative number, got '{}'",
                args.adaptive[1]
            ));
        }
        // Tolerance 0 means fixed sampling, as the README documents
        // (`-a N 0`); by the rule's letter only pixels of zero variance,
        // such as a black background, would stop early.
        (tol > 0.0).then_some(Adaptive {
            samples_per_batch: spb,
            tolerance: tol,
        })
    };
    if !(args.lens_radius >= 0.0 && args.lens_radius.is_finite()) {
        fail(format!(
            "-b: lens radius must be a non-negative number, got {}",
            args.lens_radius
        ));
    }
    if !(args.focal_distance > 0.0 && args.focal_distance.is_finite()) {
        fail(format!(
            "-d: focal distance must be a positive number, got {}",
            args.focal_distance
        ));
    }
    if let Err(e) = check_pixel_count(&args.resolution) {
        fail(e);
    }
    let region = args
        .region
        .as_deref()
        .map(|r| region(r, args.resolution[0], args.resolution[1]).unwrap_or_else(|e| fail(e)));
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = scene_path(args)
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("out");
        PathBuf::from(format!("{stem}.png"))
    });
    let format = output::Format::from_path(&output).unwrap_or_else(|e| fail(e.to_string()));
    if format == output::Format::Exr && args.tonemap != output::ToneCurve::Reference {
        eprintln!(
            "warning: --tonemap applies to PNG images; {} holds linear radiance",
            output.display()
        );
    }
    let settings = RenderSettings {
        width: args.resolution[0],
        height: args.resolution[1],
        spp: args.spp,
        centre_single_sample: true,
        // Views that are not estimates have nothing to converge.
        adaptive: adaptive.filter(|_| args.shading == View::Path && args.spp > 1),
        seed: args.seed,
        batch_size: args.batch_size as usize,
        tile_size: 16,
        lens_radius: args.lens_radius,
        focal_distance: args.focal_distance,
        integrator: Settings {
            view: args.shading,
            max_depth: args.max_depth,
            light_samples: args.light_samples,
            hemisphere: args.hemisphere,
            bounces: args.bounces,
            russian_roulette: !args.no_roulette,
            roulette_depth: args.roulette_depth,
        },
        region,
    };
    (settings, output, format)
}

/// Refuses, as a usage error, a render whose image and its encoding as
/// `format` cannot fit in the memory available (converge checks its own
/// needs instead).
fn check_memory(settings: &RenderSettings, format: output::Format) {
    if let Some(why) = memory::image_does_not_fit(settings.area().pixel_count() as u64, format) {
        let (w, h) = (settings.width, settings.height);
        usage_error::<Args>(match settings.region {
            Some(_) => format!("-r {w} {h} with -p: for the cell, {why}"),
            None => format!("-r {w} {h}: {why}"),
        });
    }
}

/// Why the output file `path` cannot be written, found out before the
/// render rather than after it: a missing folder, a folder in its place,
/// or a place that may not be written (permissions, a read-only mount, a
/// pseudo file system such as /proc). A regular file that exists is
/// opened for writing without being truncated; a name that does not exist
/// is created and removed again, the only sure test of all of these.
/// Other things (a pipe, a device, a dangling link) are left to the
/// write itself: opening a pipe would wait for a reader.
pub(crate) fn unwritable(path: &std::path::Path) -> Option<String> {
    if path
        .as_os_str()
        .to_string_lossy()
        .ends_with(std::path::MAIN_SEPARATOR)
    {
        return Some("the name ends in a path separator: a folder's name, not a file's".into());
    }
    let folder = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    if !folder.is_dir() {
        return Some(format!("there is no folder {}", folder.display()));
    }
    if path.is_dir() {
        return Some("is a folder, not a file".into());
    }
    let mut open = std::fs::OpenOptions::new();
    open.write(true);
    let probe = match path.symlink_metadata() {
        Ok(_) if path.is_file() => open.open(path).map(drop),
        Ok(_) => return None,
        Err(_) => open.create_new(true).open(path).and_then(|file| {
            drop(file);
            std::fs::remove_file(path)
        }),
    };
    probe.err().map(|e| format!("cannot write there: {e}"))
}

/// `-p X Y DX DY` as the reference reads it: the cell of columns X..X+DX
/// and rows Y..Y+DY counted from the bottom of the `width × height` image,
/// as a tile in image coordinates (row 0 at the top).
fn region(r: &[u32], width: u32, height: u32) -> std::result::Result<Tile, String> {
    let (x, y, dx, dy) = (r[0] as u64, r[1] as u64, r[2] as u64, r[3] as u64);
    if dx == 0 || dy == 0 {
        return Err(format!(
            "-p {x} {y} {dx} {dy}: the cell must be at least 1×1 pixels"
        ));
    }
    if x + dx > width as u64 || y + dy > height as u64 {
        return Err(format!(
            "-p {x} {y} {dx} {dy}: the cell reaches past the {width}×{height} image \
             (columns {x}..{}, rows {y}..{} from the bottom)",
            x + dx,
            y + dy
        ));
    }
    Ok(Tile {
        x0: x as u32,
        y0: (height as u64 - y - dy) as u32,
        width: dx as u32,
        height: dy as u32,
    })
}

/// Whether stdout failed, and how: `None` for a reader that went away.
static STDOUT_FAILED: OnceLock<Option<String>> = OnceLock::new();

/// Writes a line of a report to stdout. Once a write fails, the rest of
/// the report is dropped and the command goes on, so whatever files it
/// writes are still written. A reader that has gone (a broken pipe) is
/// not an error; any other failure (a full disk) is, at the end
/// ([`report_status`]).
pub(crate) fn say_line(line: std::fmt::Arguments) {
    use std::io::Write;
    if STDOUT_FAILED.get().is_some() {
        return;
    }
    if let Err(e) = writeln!(std::io::stdout().lock(), "{line}") {
        let _ =
            STDOUT_FAILED.set((e.kind() != std::io::ErrorKind::BrokenPipe).then(|| e.to_string()));
    }
}

/// A tool's exit status, made an error if its report could not be written.
fn report_status(status: Result<i32>) -> Result<i32> {
    match STDOUT_FAILED.get() {
        Some(Some(e)) => status.and_then(|_| Err(anyhow::anyhow!("cannot write to stdout: {e}"))),
        _ => status,
    }
}

/// `-r W H` within [`MAX_PIXELS`](crate::film::MAX_PIXELS).
fn check_pixel_count(resolution: &[u32]) -> std::result::Result<(), String> {
    let (w, h) = (resolution[0], resolution[1]);
    if w as u64 * h as u64 > crate::film::MAX_PIXELS {
        let log2 = crate::film::MAX_PIXELS.trailing_zeros();
        return Err(format!("-r {w} {h}: more than 2^{log2} pixels"));
    }
    Ok(())
}

/// A rayon pool of `-t` threads (all cores by default), and its size.
fn thread_pool(args: &Args) -> Result<(rayon::ThreadPool, usize)> {
    let threads = args.threads.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |t| t as usize,
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start worker threads")?;
    Ok((pool, threads))
}

/// The named scene, or the built-in one.
fn load_scene(args: &Args) -> Result<crate::scene::Scene> {
    // -c: the view of a CS184 viewer's camera settings file replaces the
    // scene's camera. The small file is read first, so a mistake in it is
    // reported before a large scene has been loaded.
    let camera = match &args.camera {
        Some(file) => {
            let text = read_camera_file(file)?;
            let saved = camera_file::parse(&text)
                .map_err(|e| anyhow::anyhow!("-c {}: {e}", file.display()))?;
            let (camera, note) = saved.camera(args.resolution[0], args.resolution[1]);
            if let Some(note) = note {
                eprintln!("warning: -c {}: {note}", file.display());
            }
            Some(camera)
        }
        None => None,
    };
    let environment = args.envmap.as_deref().map(load_environment).transpose()?;
    let mut scene = match &args.scene {
        Some(path) => collada::load_file(path)?,
        None => collada::load_str(DEFAULT_SCENE, std::path::Path::new(DEFAULT_SCENE_NAME))?,
    };
    if let Some(map) = environment {
        scene.lights.push(Light::Environment(Arc::new(map)));
    }
    if let (Some(camera), Some(file)) = (camera, &args.camera) {
        // What the far clipping plane cuts off is the file's camera's
        // business now, not the scene's.
        let path = args.scene.as_deref();
        let bounds = scene.geometry.bounds();
        let said = collada::far_plane_warning(
            path.unwrap_or(std::path::Path::new(DEFAULT_SCENE_NAME)),
            &scene.camera,
            &bounds,
        );
        scene.warnings.retain(|w| Some(w) != said.as_ref());
        if let Some(cut) = camera.far_plane_cuts(bounds.min, bounds.max) {
            scene.warnings.push(format!(
                "-c {}: {cut}; a larger far clip (the file's fifth number) moves the plane",
                file.display()
            ));
        }
        scene.camera = camera;
    }
    Ok(scene)
}

/// The environment map of `-e`: a latitude–longitude OpenEXR image, as
/// the CS184 renderer reads, or a Radiance HDR one (read before the
/// scene, which may be large).
pub(crate) fn load_environment(path: &std::path::Path) -> Result<EnvironmentMap> {
    let image = output::read_rgb(path).map_err(|e| anyhow::anyhow!("-e {e:#}"))?;
    EnvironmentMap::new(image.width, image.height, image.pixels)
        .map_err(|e| anyhow::anyhow!("-e {}: {e}", path.display()))
}

/// The text of a `-c` file. Such files hold 28 or 30 numbers, so at most
/// 64 KiB is read: a device (`/dev/zero`) would otherwise be read until
/// memory runs out.
fn read_camera_file(file: &std::path::Path) -> Result<String> {
    use std::io::Read;
    const LIMIT: u64 = 1 << 16;
    let cannot = |e: std::io::Error| anyhow::anyhow!("-c {}: cannot read: {e}", file.display());
    let mut text = String::new();
    std::fs::File::open(file)
        .and_then(|f| f.take(LIMIT + 1).read_to_string(&mut text))
        .map_err(cannot)?;
    if text.len() as u64 > LIMIT {
        anyhow::bail!(
            "-c {}: more than 64 KiB; not a camera settings file",
            file.display()
        );
    }
    Ok(text)
}

/// A flag that Ctrl-C sets. Failing to install the handler only loses the
/// partial output on Ctrl-C, so it is not an error.
fn cancel_on_ctrl_c() -> Arc<AtomicBool> {
    let cancel = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&cancel);
    let _ = ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed));
    cancel
}

/// Runs the command; returns the process exit status.
pub fn run() -> Result<i32> {
    let mut argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    match argv.get(1).and_then(|a| a.to_str()) {
        Some("compare") => return report_status(compare::run(argv.split_off(1))),
        Some("converge") => return report_status(converge::run(argv.split_off(1))),
        Some("mitsuba") => return mitsuba::run(argv.split_off(1)),
        _ => {}
    }
    let args = Args::parse_from(argv);
    let (settings, output_path, format) = validate(&args, usage_error::<Args>);
    check_memory(&settings, format);
    // Named as the user gave it, or as the default it took.
    let image = match args.output {
        Some(_) => format!("-f {}", output_path.display()),
        None => format!("the output {} (the default for -f)", output_path.display()),
    };
    if let Some(why) = unwritable(&output_path) {
        usage_error::<Args>(format!("{image}: {why}"));
    }
    let rate_path = output::rate_path(&output_path);
    if settings.adaptive.is_some()
        && let Some(why) = unwritable(&rate_path)
    {
        usage_error::<Args>(format!(
            "{image}: its rate image {}: {why}",
            rate_path.display()
        ));
    }
    let chatty = !args.quiet;

    let (pool, threads) = thread_pool(&args)?;

    let t = Instant::now();
    let scene = load_scene(&args)?;
    let scene_name = scene_path(&args);
    let load_time = t.elapsed();
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }

    let t = Instant::now();
    let bvh = pool.install(|| Bvh::build(&scene.geometry, args.accel));
    let build_time = t.elapsed();

    let renderer = Renderer::new(&scene, &bvh);
    if settings.integrator.view == View::Path {
        for w in &renderer.warnings {
            eprintln!("warning: {}: {w}", scene_name.display());
        }
        for note in settings.integrator.blind_spots(&scene.lights) {
            eprintln!("warning: {note}");
        }
        // The renderer's lights are every emitter (emissive meshes and
        // spheres too): without one, nothing in the scene emits, whatever -m.
        if renderer.lights.is_empty() {
            let map = |l: &Light| matches!(l, Light::Environment(_));
            let why = if scene.lights.is_empty() {
                "the scene has no lights"
            } else if scene.lights.iter().all(map) {
                "the environment map is black"
            } else if scene.lights.iter().any(map) {
                "no light of the scene emits (every light's colour is 0 0 0, and the \
                 environment map is black)"
            } else {
                "no light of the scene emits (every light's colour is 0 0 0)"
            };
            eprintln!(
                "warning: {}: {why} and no surface is emissive: nothing emits, so the image \
                 is black",
                scene_name.display()
            );
        }
    }

    // Ctrl-C stops the render between passes; what is done is still written.
    let cancel = cancel_on_ctrl_c();

    let total_work = Renderer::progress_total(&settings);
    let bar = if chatty && std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(total_work);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {percent}% ETA {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    // Without a terminal (a log, a pipe): a line every ten seconds instead.
    let lines = (chatty && bar.is_hidden())
        .then(|| report::ProgressLines::new(total_work, std::time::Duration::from_secs(10)));
    let t = Instant::now();
    let on_progress = |units: u64| {
        bar.inc(units);
        if let Some(line) = lines.as_ref().and_then(|l| l.advance(units, t.elapsed())) {
            eprintln!("{line}");
        }
    };
    let result = pool.install(|| renderer.render(&settings, &on_progress, &cancel));
    let render_time = t.elapsed();
    bar.finish_and_clear();

    let with_rate = settings.adaptive.is_some();
    let bad = result.image.non_finite_count();
    if bad > 0 {
        // Image files get 0 there; said, so that it is not taken for black.
        eprintln!(
            "warning: {bad} pixels of {} are NaN or infinite (radiance beyond f32's range: a \
             colour or emission of the scene too large?); written as 0",
            scene_name.display()
        );
    }
    // An EXR holds the sample counts where they vary: adaptive sampling,
    // or a render stopped between two passes of some tiles.
    let with_counts = with_rate || !result.complete;
    output::write_image(&result.image, &output_path, args.tonemap, with_counts)?;
    if with_rate {
        output::write_rate_png(&result.image, settings.spp, &rate_path)?;
    }

    if chatty {
        report::timings(
            &output_path,
            load_time,
            build_time,
            render_time,
            &result,
            threads,
            settings.adaptive.map(|_| settings.spp),
        );
    }
    if args.stats {
        let shading_bytes = renderer.triangles.memory_bytes();
        report::stats(
            (&scene, &renderer.lights),
            (&bvh, shading_bytes),
            &result.stats,
            render_time,
            threads,
        );
    }
    if !result.complete {
        eprintln!(
            "interrupted: wrote the part rendered so far to {}",
            output_path.display()
        );
        return Ok(EXIT_INTERRUPTED);
    }
    Ok(0)
}

/// A fresh, empty folder for one unit test's files, named by the process
/// and `tag` (a binary's tests run at once, so each uses its own tag); the
/// test removes it when done.
#[cfg(test)]
pub(crate) fn scratch_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wavepath-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_region_may_reach_the_images_edges_but_not_past_them() {
        // The whole 64×48 image, and cells flush with its right and top
        // edges; rows from the bottom become rows from the top.
        let whole = region(&[0, 0, 64, 48], 64, 48).unwrap();
        assert_eq!(
            (whole.x0, whole.y0, whole.width, whole.height),
            (0, 0, 64, 48)
        );
        let top_right = region(&[60, 45, 4, 3], 64, 48).unwrap();
        assert_eq!(
            (
                top_right.x0,
                top_right.y0,
                top_right.width,
                top_right.height
            ),
            (60, 0, 4, 3)
        );
        let bottom_left = region(&[0, 0, 1, 1], 64, 48).unwrap();
        assert_eq!((bottom_left.x0, bottom_left.y0), (0, 47));
        for past in [[61, 0, 4, 3], [0, 46, 4, 3], [64, 0, 1, 1], [0, 48, 1, 1]] {
            let e = region(&past, 64, 48).unwrap_err();
            assert!(e.contains("reaches past the 64×48 image"), "{past:?}: {e}");
        }
        // Sums that would overflow u32 are still refused, not wrapped.
        assert!(region(&[u32::MAX, 0, 2, 1], 64, 48).is_err());
        assert!(region(&[0, 0, 0, 1], 64, 48).unwrap_err().contains("1×1"));
    }

    #[test]
    fn the_pixel_limit_is_inclusive() {
        let side = 1u32 << (crate::film::MAX_PIXELS.trailing_zeros() / 2);
        assert!(check_pixel_count(&[side, side]).is_ok());
        assert!(check_pixel_count(&[side, side + 1]).is_err());
        assert!(check_pixel_count(&[65536, 65536]).is_err());
    }

    #[test]
    fn camera_files_are_read_up_to_64_kib() {
        let dir = scratch_dir("camera-file");
        let file = dir.join("camera.txt");
        std::fs::write(&file, " ".repeat(1 << 16)).unwrap();
        assert_eq!(read_camera_file(&file).unwrap().len(), 1 << 16);
        std::fs::write(&file, " ".repeat((1 << 16) + 1)).unwrap();
        let e = read_camera_file(&file).unwrap_err().to_string();
        assert!(e.contains("camera.txt") && e.contains("64 KiB"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
