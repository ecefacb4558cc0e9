//! The `wavepath` command as a user runs it.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use wavepath::film::output::read_image;

fn wavepath(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .args(args)
        .output()
        .expect("run wavepath")
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `wavepath args… -f out scene`.
fn render_to(scene: &str, out: &Path, args: &[&str]) -> Output {
    let mut all = args.to_vec();
    all.extend_from_slice(&["-f", out.to_str().unwrap(), scene]);
    wavepath(&all)
}

/// Writes `text` as the scene `<name>.dae` and renders it with `args` at
/// 400×300 (a W×H render is the central crop of the 800×600 view, and at
/// this size it takes in the minimal fixture's objects) to `<name>.exr`.
/// The run must succeed; returns the output image's path and stderr.
fn render_text(name: &str, text: &str, args: &[&str]) -> (PathBuf, String) {
    let scene = scratch(&format!("{name}.dae"));
    std::fs::write(&scene, text).unwrap();
    let out = scratch(&format!("{name}.exr"));
    let o = render_to(
        scene.to_str().unwrap(),
        &out,
        &[args, &["-r", "400", "300"]].concat(),
    );
    assert!(o.status.success(), "{name}: {}", stderr(&o));
    (out, stderr(&o))
}

#[test]
fn renders_the_shipped_scene_to_png_and_exr() {
    let png = scratch("cornell.png");
    let exr = scratch("cornell.exr");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    for out in [&png, &exr] {
        let o = wavepath(&[
            "-q",
            "-s",
            "2",
            "-m",
            "1",
            "-r",
            "480",
            "360",
            "-f",
            out.to_str().unwrap(),
            scene,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let a = read_image(&png).unwrap();
    let b = read_image(&exr).unwrap();
    assert_eq!((a.width, a.height), (480, 360));
    assert_eq!((b.width, b.height), (480, 360));
    assert!(
        b.pixels
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0)
    );
    // Framed like the reference's Cornell boxes: the light near the top
    // centre, the red wall on the left, the blue wall on the right.
    let light = b.at(240, 40);
    assert!(light.x > 5.0, "light pixel {light}");
    let (left, right) = (b.at(30, 180), b.at(450, 180));
    assert!(left.x > 2.0 * left.z, "left wall is not red: {left}");
    assert!(right.z > 2.0 * right.x, "right wall is not blue: {right}");
    // Adaptive sampling (the default) writes the sample-rate image too.
    assert!(scratch_exists("cornell_rate.png"));
}

/// The same seed writes the same EXR file, byte for byte, from run to run
/// and on 1 or 2 render threads: its blocks are declared and written in
/// increasing order, not in the order the encoder's own thread pool
/// finishes compressing them (which made equal images differ as files in
/// most runs before).
#[test]
fn exr_files_are_reproducible() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let bytes: Vec<Vec<u8>> = ["1", "2", "2", "2"]
        .iter()
        .enumerate()
        .map(|(k, threads)| {
            let out = scratch(&format!("repro{k}.exr"));
            let o = wavepath(&[
                "-q",
                "-s",
                "2",
                "-m",
                "2",
                "-t",
                threads,
                "-r",
                "320",
                "240",
                "-f",
                out.to_str().unwrap(),
                scene,
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
            std::fs::read(&out).unwrap()
        })
        .collect();
    for (k, b) in bytes.iter().enumerate().skip(1) {
        assert!(*b == bytes[0], "run {k} wrote a different file");
    }
    // Byte equality of a few runs can hold by luck; the declared order is
    // what makes it hold always.
    let meta = exr::meta::MetaData::read_from_file(scratch_path("repro0.exr"), false).unwrap();
    assert_eq!(
        meta.headers[0].line_order,
        exr::meta::attribute::LineOrder::Increasing
    );
}

/// A scratch file's path without deleting it.
fn scratch_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli")
        .join(name)
}

fn scratch_exists(name: &str) -> bool {
    scratch_path(name).is_file()
}

#[test]
fn the_built_in_scene_renders_with_no_arguments_but_output() {
    let out = scratch("builtin.png");
    let o = wavepath(&["-q", "-r", "32", "24", "-f", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.is_file());
}

#[test]
fn normals_view_works_for_every_cs184_scene() {
    let Some(dir) = common::cs184_dir() else {
        return;
    };
    let out = scratch("normals.png");
    for scene in common::dae_files(&dir) {
        let o = wavepath(&[
            "-q",
            "--shading",
            "normals",
            "-s",
            "1",
            "-r",
            "480",
            "360",
            "-f",
            out.to_str().unwrap(),
            scene.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}: {}", scene.display(), stderr(&o));
        let image = read_image(&out).unwrap();
        let lit = image
            .pixels
            .iter()
            .filter(|p| p.max_element() > 0.0)
            .count();
        assert!(
            lit > 480 * 360 / 50,
            "{}: the scene is barely in view ({lit} pixels)",
            scene.display()
        );
    }
}

#[test]
fn nonsense_values_are_refused_with_a_usage_hint() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    for args in [
        vec!["-s", "0", scene],
        vec!["-r", "0", "100", scene],
        vec!["-a", "32", "-1", scene],
        vec!["-a", "0", "0.05", scene],
        vec!["-l", "0", scene],
        // Past the limits that keep memory and threads bounded.
        vec!["-l", "1025", scene],
        vec!["-l", "4294967295", scene],
        vec!["-t", "0", scene],
        vec!["-t", "4294967295", scene],
        // Found before rendering, not after.
        vec!["-f", "no/such/folder/out.exr", scene],
        vec!["-f", "out.jpg", scene],
        vec!["--shading", "wireframe", scene],
        vec!["-p", "0", "0", "801", "10", scene],
        vec!["-r", "65536", "65536", scene],
        // A list flag given twice, as any flag: an error, not its first list.
        vec!["-r", "64", "48", "-r", "48", "48", scene],
        vec!["-a", "4", "0.1", "-a", "8", "0.1", scene],
        vec!["--roulette-depth", "-1", scene],
        // Flags that contradict each other.
        vec!["--no-adaptive", "-a", "8", "0.1", scene],
        vec!["--no-roulette", "--roulette-depth", "2", scene],
    ] {
        let o = wavepath(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(err.contains("--help"), "{args:?}: no usage hint: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    // Values of the right type that break a rule of their flag: the
    // message names the flag and the value (not clap's "unexpected
    // argument '-1'", which a negative number would otherwise get).
    let lens = "-b: lens radius must be a non-negative number";
    let focus = "-d: focal distance must be a positive number";
    for (flag, value, rule) in [
        ("-b", "-1", lens),
        ("-b", "inf", lens),
        ("-b", "NaN", lens),
        ("-d", "0", focus),
        ("-d", "-2", focus),
        ("-d", "inf", focus),
    ] {
        let o = wavepath(&[flag, value, scene]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {err}");
        let says = format!("error: {rule}, got {value}");
        assert!(err.starts_with(&says), "{flag} {value}: {err}");
    }
}

#[test]
fn outputs_that_cannot_be_written_are_refused_before_rendering() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    // A folder where the image should go, for the image and for the rate
    // image of an adaptive render.
    let folder = scratch_path("taken.png");
    std::fs::create_dir_all(&folder).unwrap();
    let rate_folder = scratch_path("adaptive_rate.png");
    std::fs::create_dir_all(&rate_folder).unwrap();
    let adaptive = scratch("adaptive.png");
    let mut cases = vec![
        (
            vec!["-f", folder.to_str().unwrap(), scene],
            format!("-f {}: is a folder", folder.display()),
        ),
        (
            vec!["-s", "64", "-f", adaptive.to_str().unwrap(), scene],
            format!(
                "-f {}: its rate image {}: is a folder",
                adaptive.display(),
                rate_folder.display()
            ),
        ),
    ];
    let slash = format!("{}/", scratch_path("slash.png").display());
    cases.push((
        vec!["-f", &slash, scene],
        format!("-f {slash}: the name ends in a path separator"),
    ));
    // A file system that takes no new files (Linux's /proc).
    if Path::new("/proc/self").is_dir() {
        cases.push((
            vec!["-f", "/proc/wavepath.png", scene],
            "-f /proc/wavepath.png: cannot write there".into(),
        ));
    }
    for (args, says) in cases {
        let o = wavepath(&args);
        let err = stderr(&o);
        // Status 2 with a usage hint: the check before the render, not a
        // failed write after it (status 1).
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.starts_with(&format!("error: {says}")),
            "{args:?}: {err}"
        );
        assert!(err.contains("--help"), "{args:?}: {err}");
    }
    // Without -f, the default name is the one named (here, in a folder
    // that holds a folder of that name).
    let cwd = scratch_path("default-name");
    std::fs::create_dir_all(cwd.join("cornell.png")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .args(["-r", "8", "6", scene])
        .current_dir(&cwd)
        .output()
        .expect("run wavepath");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).starts_with("error: the output cornell.png (the default for -f): is a folder"),
        "{}",
        stderr(&o)
    );

    // At one sample per pixel sampling is not adaptive and no rate image
    // is written, so the same name is fine.
    let o = wavepath(&[
        "-q",
        "-r",
        "8",
        "6",
        "-f",
        adaptive.to_str().unwrap(),
        scene,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    // A file that may not be written (where permissions bind: root
    // writes through them).
    let read_only = scratch("read-only.png");
    std::fs::write(&read_only, b"kept").unwrap();
    let mut permissions = std::fs::metadata(&read_only).unwrap().permissions();
    permissions.set_readonly(true);
    std::fs::set_permissions(&read_only, permissions).unwrap();
    if std::fs::OpenOptions::new()
        .write(true)
        .open(&read_only)
        .is_ok()
    {
        println!("skipped the read-only file: this user writes through permissions");
    } else {
        let o = wavepath(&["-f", read_only.to_str().unwrap(), scene]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        let says = format!("error: -f {}: cannot write there", read_only.display());
        assert!(stderr(&o).starts_with(&says), "{}", stderr(&o));
        assert_eq!(std::fs::read(&read_only).unwrap(), b"kept");
    }
    let mut permissions = std::fs::metadata(&read_only).unwrap().permissions();
    #[allow(clippy::permissions_set_readonly_false)]
    permissions.set_readonly(false);
    std::fs::set_permissions(&read_only, permissions).unwrap();

    // A link to a file not made yet is written through, as before the check.
    #[cfg(unix)]
    {
        let target = scratch("link-target.png");
        let link = scratch("link.png");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let o = wavepath(&["-q", "-r", "8", "6", "-f", link.to_str().unwrap(), scene]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(target.is_file());
    }

    // The check leaves nothing behind: a new file it made is removed when
    // a later step fails, and a file that exists keeps its bytes.
    let fresh = scratch("probe-fresh.png");
    let o = wavepath(&["-q", "-f", fresh.to_str().unwrap(), "no/such/scene.dae"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(!fresh.exists(), "the probe's file was left behind");
    let kept = scratch("probe-kept.png");
    std::fs::write(&kept, b"earlier render").unwrap();
    let o = wavepath(&["-q", "-f", kept.to_str().unwrap(), "no/such/scene.dae"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(std::fs::read(&kept).unwrap(), b"earlier render");
}

/// Settings that leave light out of the image by construction, or a flag
/// that does nothing for the output asked for, render as asked with a
/// warning saying so.
#[test]
fn settings_that_leave_light_out_are_warned_about() {
    let point_light = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/point_light.dae");
    let cornell = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let png = scratch("warned.png");
    let exr = scratch("warned.exr");
    let (png, exr) = (png.to_str().unwrap(), exr.to_str().unwrap());
    for (args, warning) in [
        (
            vec!["-H", "-f", png, point_light],
            Some(
                "uniform hemisphere sampling (-H) never finds the scene's 1 point or directional light",
            ),
        ),
        (vec!["-f", png, point_light], None),
        // The Cornell box's light is an area light, which -H finds.
        (vec!["-H", "-f", png, cornell], None),
        (
            vec!["--bounces", "indirect", "-m", "1", "-f", png, cornell],
            Some("--bounces indirect keeps light that bounced twice or more, and -m 1"),
        ),
        (
            vec!["--bounces", "indirect", "-m", "2", "-f", png, cornell],
            None,
        ),
        (
            vec!["--tonemap", "srgb", "-f", exr, cornell],
            Some("--tonemap applies to PNG images"),
        ),
        (vec!["--tonemap", "srgb", "-f", png, cornell], None),
    ] {
        let all = [&["-q", "-r", "8", "6"][..], &args].concat();
        let o = wavepath(&all);
        let err = stderr(&o);
        assert!(o.status.success(), "{all:?}: {err}");
        match warning {
            Some(w) => assert!(err.contains(&format!("warning: {w}")), "{all:?}: {err}"),
            None => assert!(!err.contains("warning"), "{all:?}: {err}"),
        }
    }
}

/// An image whose film cannot fit in the memory the process may use is
/// refused before anything loads, naming both sizes, instead of ending in
/// an allocation failure (an abort). `ulimit -v` stands in for a small
/// machine.
#[test]
#[cfg(target_os = "linux")]
fn an_image_too_large_for_memory_is_refused_up_front() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let out = scratch("too_large.png");
    let limited = |args: &[&str]| {
        Command::new("sh")
            .arg("-c")
            .arg("ulimit -v 1000000 && exec \"$0\" \"$@\"")
            .arg(env!("CARGO_BIN_EXE_wavepath"))
            .args(args)
            .output()
            .expect("run wavepath under sh")
    };
    // Refused with exit status `code` (2: -r is a flag every command
    // refuses with its usage line), the message starting `start` and
    // giving the memory available.
    let refused = |args: &[&str], code: i32, start: &str| {
        let o = limited(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{err}");
        assert!(err.starts_with(start), "{err}");
        assert!(err.contains("GiB of memory is available"), "{err}");
    };
    // 64 M pixels: 1.7 GiB of image and 0.18 GiB of PNG buffer (more
    // than the 0.14 GiB of sums for the 2 M pixels rendered at once, freed
    // before it), against under 1 GB of address space.
    let (out_arg, big) = (out.to_str().unwrap(), ["-r", "8000", "8000"]);
    refused(
        &[&["-q"], &big[..], &["-f", out_arg, scene]].concat(),
        2,
        "error: -r 8000 8000: the image, the sums of the pixels being rendered and the PNG \
         encoding need 1.8 GiB, and ",
    );
    assert!(!out.exists());
    // A small cell of the same image fits, and renders (on two threads,
    // whatever the machine: each thread's stack takes address space).
    let o = limited(
        &[
            &["-q", "-t", "2"],
            &big[..],
            &["-p", "0", "0", "64", "48", "-f", out_arg, scene],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // A reference holds a replicate and the replicates' running sums: 16 M
    // pixels of them (1.0 GiB, and the sums) do not fit where a render's
    // image and its PNG buffer (0.46 GiB, and the sums) would.
    let reference = scratch("too_large_reference.exr");
    let ref_arg = reference.to_str().unwrap();
    refused(
        &[
            "converge",
            "--make-reference",
            "-r",
            "4000",
            "4000",
            "--ref",
            ref_arg,
            scene,
        ],
        2,
        "error: -r 4000 4000: a replicate and the replicates' running sums, and the sums \
         of the pixels being rendered, need 1.2 GiB, and ",
    );
    assert!(!reference.exists());
    // Measuring holds the reference and a render (converge writes no
    // image, so a render's PNG check does not apply to it).
    refused(
        &[&["converge"], &big[..], &["--ref", ref_arg, scene]].concat(),
        2,
        "error: -r 8000 8000: the reference and a render, and the sums of the pixels being \
         rendered, need 3.5 GiB, and ",
    );
}

/// `-e` lights a scene with a latitude–longitude EXR, which camera rays
/// see too: the fixture without its lamp, under a uniform map, shows the
/// map's colour exactly wherever it misses the objects, lit objects
/// elsewhere, and no warning that nothing lights it. A map that cannot be
/// used is one line naming the file (and the texel at fault), exit 1, and
/// no image. The shipped map (`scenes/sky.exr`) lights the shipped
/// `scenes/outdoor.dae`, and a Radiance HDR map lights it as an EXR of the
/// same texels does.
#[test]
fn environment_maps_light_the_scene_and_bad_ones_are_named() {
    use glam::Vec3;
    let unlit = include_str!("fixtures/minimal.dae").replace("<instance_light url=\"#lamp\"/>", "");
    let colour = Vec3::new(0.25, 0.5, 1.0);
    // One row of texels (the renderer's own EXR writer would turn a NaN to 0).
    let write_map = |name: &str, texels: &[Vec3]| {
        let path = scratch(name);
        exr::prelude::write_rgb_file(&path, texels.len(), 1, |x, _| texels[x].into()).unwrap();
        path
    };
    let sky = write_map("uniform_sky.exr", &[colour; 4]);
    let args = [
        "-e",
        sky.to_str().unwrap(),
        "-s",
        "4",
        "-m",
        "2",
        "--no-adaptive",
    ];
    let (out, err) = render_text("under_sky", &unlit, &args);
    assert!(!err.contains("no light"), "{err}");
    let image = read_image(&out).unwrap();
    let seen = image.pixels.iter().filter(|p| **p == colour).count();
    let lit = image
        .pixels
        .iter()
        .filter(|p| **p != colour && p.max_element() > 0.0)
        .count();
    assert!(
        seen > 10_000 && lit > 1_000,
        "{seen} sky pixels, {lit} lit ones"
    );

    // The shipped sky over the shipped lightless scene: the camera looks
    // down on the ground, so the image's top corners show the map below
    // its horizon (one colour there, to rounding), not the blue above it.
    let root = env!("CARGO_MANIFEST_DIR");
    // The shipped lightless scene under `map`, 2 spp, `-m 2`, at `size`.
    let outdoor = |map: &str, size: [&str; 2], out: PathBuf| {
        let args = [
            "-q", "-s", "2", "-m", "2", "-r", size[0], size[1], "-e", map,
        ];
        let o = render_to(&format!("{root}/scenes/outdoor.dae"), &out, &args);
        assert!(o.status.success(), "{}", stderr(&o));
        read_image(&out).unwrap()
    };
    let sky = format!("{root}/scenes/sky.exr");
    let image = outdoor(&sky, ["480", "360"], scratch("outdoor.exr"));
    let ground = Vec3::new(0.15, 0.12, 0.09);
    for corner in [image.at(0, 0), image.at(479, 0)] {
        assert!((corner - ground).abs().max_element() < 1e-6, "{corner}");
    }
    assert!(
        image.at(240, 300).min_element() > 0.05,
        "{}",
        image.at(240, 300)
    );

    // A Radiance HDR map lights a scene exactly as an EXR of the same
    // texels does (powers of two within 2⁸ of a texel's brightest
    // channel: exact in RGBE), west to east and top to bottom alike.
    let texels: Vec<Vec3> = (0..8)
        .map(|k| Vec3::new(0.25, 2.0, 0.5) * 2f32.powi(k % 4 - 1 + 2 * (k / 4)))
        .collect();
    let hdr = scratch("sky.hdr");
    let rgb: Vec<image::Rgb<f32>> = texels.iter().map(|t| image::Rgb(t.to_array())).collect();
    image::codecs::hdr::HdrEncoder::new(std::fs::File::create(&hdr).unwrap())
        .encode(&rgb, 4, 2)
        .unwrap();
    let exr_map = scratch("sky_of_hdr.exr");
    exr::prelude::write_rgb_file(&exr_map, 4, 2, |x, y| texels[y * 4 + x].into()).unwrap();
    let renders = [&hdr, &exr_map].map(|map| {
        let name = format!("under_{}.exr", map.extension().unwrap().to_str().unwrap());
        outdoor(map.to_str().unwrap(), ["64", "48"], scratch(&name))
    });
    assert!(renders[0].pixels.iter().any(|p| p.max_element() > 0.0));
    assert!(
        renders[0].pixels == renders[1].pixels,
        "the .hdr and .exr renders differ"
    );

    let nan = write_map("nan_sky.exr", &[colour, Vec3::new(1.0, f32::NAN, 0.0)]);
    let text = scratch("not_exr.exr");
    std::fs::write(&text, "not an image").unwrap();
    let text_hdr = scratch("not_hdr.hdr");
    std::fs::write(&text_hdr, "not an image").unwrap();
    // A header alone can claim 10¹⁰ texels: refused before any is read.
    let huge_hdr = scratch("huge.hdr");
    std::fs::write(
        &huge_hdr,
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n",
    )
    .unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    for (map, says) in [
        (scratch("missing_sky.exr"), "cannot read EXR".to_string()),
        (
            scratch("missing_sky.hdr"),
            "cannot read Radiance HDR".into(),
        ),
        (
            PathBuf::from("sky.png"),
            "environment maps are read from OpenEXR (.exr) or Radiance HDR (.hdr) files".into(),
        ),
        (text, "not an OpenEXR file".into()),
        (text_hdr, "cannot read Radiance HDR".into()),
        (huge_hdr, "claims 100000x100000 pixels".into()),
        (
            nan,
            "texel (1, 0) (column, row from the top) is 1 NaN 0".into(),
        ),
    ] {
        let out = scratch("bad_sky.png");
        let o = render_to(scene, &out, &["-q", "-e", map.to_str().unwrap()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        let named = format!("error: -e {}: ", map.display());
        assert!(err.starts_with(&named) && err.contains(&says), "{err}");
        assert!(!out.exists(), "{err}");
    }
}

#[test]
fn a_missing_scene_is_one_line_and_exit_1() {
    let o = wavepath(&["-q", "no/such/scene.dae"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("no/such/scene.dae"), "{err}");
}

#[test]
fn stats_report_every_stage() {
    let out = scratch("stats.png");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let o = wavepath(&[
        "-q",
        "--stats",
        "-s",
        "4",
        "-m",
        "3",
        "-r",
        "32",
        "24",
        "-f",
        out.to_str().unwrap(),
        scene,
    ]);
    assert!(o.status.success());
    let err = stderr(&o);
    for stage in [
        "generate",
        "intersect",
        "shade",
        "shadow-test",
        "compact",
        "nodes visited/ray",
    ] {
        assert!(err.contains(stage), "--stats lacks {stage}: {err}");
    }
    // No -H: the probe stage has no work and is reported as skipped.
    assert!(
        err.lines()
            .any(|l| l.starts_with("probe") && l.contains("skipped")),
        "{err}"
    );
}

#[test]
fn roulette_depth_decides_where_paths_may_end() {
    // Path vertices shaded (the `shade` line of --stats) for a given
    // roulette setting. A path continues from vertex d only if d + 1 < -m,
    // and roulette applies at vertices d >= --roulette-depth.
    let out = scratch("roulette.png");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let vertices = |depth: &str, extra: &[&str]| -> u64 {
        let mut args = vec!["-q", "--stats", "-s", "8", "-m", depth, "-r", "32", "24"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-f", out.to_str().unwrap(), scene]);
        let o = wavepath(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        let line = err
            .lines()
            .find(|l| l.starts_with("shade"))
            .unwrap_or_else(|| panic!("no shade line: {err}"));
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    // -m 8: the default (from vertex 5) plays at vertices 5 and 6.
    let early = vertices("8", &["--roulette-depth", "1"]);
    let default = vertices("8", &[]);
    let off = vertices("8", &["--no-roulette"]);
    assert!(
        early < default && default < off,
        "{early} / {default} / {off}"
    );
    // -m 7: paths continue from vertices 0..=5, so roulette from vertex 6
    // never plays and from vertex 5 does.
    let off = vertices("7", &["--no-roulette"]);
    assert_eq!(vertices("7", &["--roulette-depth", "6"]), off);
    assert!(vertices("7", &["--roulette-depth", "5"]) < off);
}

#[test]
fn ctrl_c_writes_what_was_rendered() {
    let out = scratch("interrupted.exr");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    // Far more work than the test waits for (adaptive at a tolerance no
    // pixel meets, or fixed), in passes of 16 samples: ~20 ms each over
    // the image here on two threads.
    for sampling in [&["-a", "32", "0.00001"][..], &["--no-adaptive"]] {
        let child = Command::new(env!("CARGO_BIN_EXE_wavepath"))
            .args(["-s", "100000", "-m", "5", "-r", "80", "60"])
            .args(sampling)
            .arg("-f")
            .arg(&out)
            .arg(scene)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(1500));
        let killed = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(
            err.contains("interrupted: wrote the part rendered"),
            "{err}"
        );
        // Pixels cut short are not taken for pixels that converged.
        assert!(
            err.contains(" pixels rendered, ") && !err.contains("stopped before"),
            "{err}"
        );
        let image = read_image(&out).unwrap();
        assert!(image.pixels.iter().all(|p| p.is_finite()));
        assert!(
            image.pixels.iter().any(|p| p.max_element() > 0.0),
            "nothing was kept"
        );
        // Tiles take their passes in turn: the whole image is sampled,
        // every pixel within one pass of every other, and the EXR says
        // how many samples each took (also without adaptive sampling).
        let (least, most) = (
            image.samples.iter().min().unwrap(),
            image.samples.iter().max().unwrap(),
        );
        assert!(
            *least >= 16 && most - least <= 16 && least % 16 == 0,
            "{sampling:?}: {least}..{most} samples"
        );
        assert!(err.contains("4800 of 4800 pixels rendered"), "{err}");
    }
}

#[test]
fn non_finite_pixels_are_said_and_written_as_zero() {
    // Walls of albedo 3e38: the second bounce's throughput overflows to
    // infinity, which the files cannot hold; the user must be told, not
    // shown a black pixel as if it were one.
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae"))
        .unwrap()
        .replace("0.6 0.6 0.6 1", "3e38 3e38 3e38 1");
    let scene = scratch("overflow.dae");
    std::fs::write(&scene, text).unwrap();
    let out = scratch("overflow.exr");
    let o = render_to(
        scene.to_str().unwrap(),
        &out,
        &[
            "-q",
            "--no-adaptive",
            "-s",
            "2",
            "-m",
            "3",
            "-r",
            "24",
            "18",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("reflects more light than it receives"),
        "{err}"
    );
    assert!(
        err.contains("pixels of ") && err.contains(".dae are NaN or infinite"),
        "{err}"
    );
    let image = read_image(&out).unwrap();
    assert!(image.pixels.iter().all(|p| p.is_finite()));
}

/// A scene that nothing lights renders what it emits — here nothing, so
/// black — exits 0 and says why, once, at any `-m`; a light of colour
/// 0 0 0 lights nothing and is said to. A lit scene gets no warning, nor
/// does an unlit one with an emissive surface (it shows that surface). The
/// renders trace camera rays only: where nothing emits, no shadow or
/// continuation ray can bring light. (A W×H render is the central
/// crop of the 800×600 view, so it is large enough to take in the objects.)
#[test]
fn a_scene_without_light_warns_once_and_renders_black() {
    let lit = include_str!("fixtures/minimal.dae");
    let dark = lit.replace("<color>1 1 1</color>", "<color>0 0 0</color>");
    let unlit = lit.replace("<instance_light url=\"#lamp\"/>", "");
    let glowing = unlit.replace(
        "</profile_COMMON>",
        "</profile_COMMON><extra><technique profile=\"CGL\"><emission>\
         <radiance>1 1 1</radiance></emission></technique></extra>",
    );
    assert!(
        dark != lit && unlit != lit && glowing != unlit,
        "the fixture changed"
    );
    let cases = [
        ("lit", lit, "2", None),
        (
            "dark",
            dark.as_str(),
            "2",
            Some("every light's colour is 0 0 0"),
        ),
        (
            "unlit",
            unlit.as_str(),
            "2",
            Some("the scene has no lights"),
        ),
        (
            "unlit-m0",
            unlit.as_str(),
            "0",
            Some("the scene has no lights"),
        ),
        ("glowing", glowing.as_str(), "2", None),
    ];
    for (name, text, depth, says) in cases {
        let (out, err) = render_text(name, text, &["-q", "--stats", "-s", "2", "-m", depth]);
        let warnings: Vec<&str> = err
            .lines()
            .filter(|l| l.contains("nothing emits, so the image is black"))
            .collect();
        let image = read_image(&out).unwrap();
        let brightest = image
            .pixels
            .iter()
            .map(|p| p.max_element())
            .fold(0.0, f32::max);
        match says {
            Some(reason) => {
                assert_eq!(warnings.len(), 1, "{name}: {err}");
                assert!(warnings[0].contains(reason), "{name}: {err}");
                assert!(
                    warnings[0].contains(&format!("{name}.dae")),
                    "{name}: {err}"
                );
                assert_eq!(brightest, 0.0, "{name}: nothing emits, yet a pixel is lit");
            }
            None => {
                assert!(warnings.is_empty(), "{name}: {err}");
                assert!(brightest > 0.0, "{name}: the lit scene rendered black");
            }
        }
        let emitters = match name {
            "lit" => "1 point light",
            "dark" => "1 light of colour 0",
            "glowing" => "1 emissive sphere, 1 emissive triangle",
            _ => "none",
        };
        assert!(
            err.contains(&format!("; emitters: {emitters}\n")),
            "{name}: {err}"
        );
    }
}

/// The items column of a `--stats` stage line, `None` when the stage was skipped.
fn stage_items(err: &str, stage: &str) -> Option<u64> {
    let line = err
        .lines()
        .find(|l| l.starts_with(stage))
        .unwrap_or_else(|| panic!("no {stage} line: {err}"));
    let items = line[stage.len()..].split_whitespace().next().unwrap();
    (items != "skipped").then(|| items.parse().unwrap())
}

/// `--stats` counts what each stage did, and a stage with nothing to do is
/// not run: no continuation rays at `-m 0` and `-m 1`, no shadow rays at
/// `-m 0` or without a light, no camera rays for pixels that converged.
#[test]
fn stats_count_each_stage_and_idle_stages_are_skipped() {
    let cornell = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let out = scratch("stages.png");
    let run = |scene: &str, args: &[&str]| -> String {
        let o = render_to(
            scene,
            &out,
            &[&["-q", "--stats", "-r", "32", "24"], args].concat(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let camera_rays = 32 * 24 * 4;
    let fixed = ["-s", "4", "--no-adaptive"];

    let err = run(cornell, &[&fixed[..], &["-m", "0"]].concat());
    assert_eq!(stage_items(&err, "generate"), Some(camera_rays), "{err}");
    assert_eq!(stage_items(&err, "intersect"), Some(camera_rays), "{err}");
    assert_eq!(stage_items(&err, "shadow-test"), None, "{err}");

    let err = run(cornell, &[&fixed[..], &["-m", "1"]].concat());
    assert_eq!(stage_items(&err, "intersect"), Some(camera_rays), "{err}");
    assert!(stage_items(&err, "shadow-test").unwrap() > 0, "{err}");

    let err = run(cornell, &[&fixed[..], &["-m", "3"]].concat());
    assert!(
        stage_items(&err, "intersect").unwrap() > camera_rays,
        "{err}"
    );

    // -l: samples per area light, each a shadow ray (the box's one light
    // is seen whole from every point that sees it at all); -H replaces
    // them with hemisphere probes.
    let shadow_rays = |l: &str| {
        let err = run(cornell, &[&fixed[..], &["-m", "1", "-l", l]].concat());
        stage_items(&err, "shadow-test").unwrap() as f64
    };
    let ratio = shadow_rays("3") / shadow_rays("1");
    assert!(
        (ratio - 3.0).abs() < 0.03,
        "-l 3 traced {ratio}× the shadow rays of -l 1"
    );
    // -H: N = lights × -l probes at every diffuse hit, whether or not it
    // sees a light (at -m 1 the hits are the camera rays' alone, the same
    // in both runs).
    let probes = |l: &str| {
        let err = run(cornell, &[&fixed[..], &["-m", "1", "-H", "-l", l]].concat());
        assert_eq!(stage_items(&err, "shadow-test"), None, "{err}");
        stage_items(&err, "probe (-H)").unwrap()
    };
    let one = probes("1");
    assert!(one > 0);
    assert_eq!(probes("3"), 3 * one);

    // Converged pixels drop out: fewer camera rays than -s asks for, in
    // whole batches of -a's first number per pixel.
    let err = run(cornell, &["-s", "64", "-a", "4", "0.5", "-m", "1"]);
    let generated = stage_items(&err, "generate").unwrap();
    assert!(
        generated < 32 * 24 * 64 && generated.is_multiple_of(4),
        "{err}"
    );

    // The minimal fixture with and without its light: the same hits, and
    // shadow rays only when there is a light to test.
    let lit = include_str!("fixtures/minimal.dae");
    let unlit = lit.replace("<instance_light url=\"#lamp\"/>", "");
    // Unlit, nothing emits: no continuation rays either (only camera rays
    // are traced, 400 × 300 of them).
    for (name, text, lit) in [("stages-lit", lit, true), ("stages-unlit", &unlit, false)] {
        let (_, err) = render_text(name, text, &["-q", "--stats", "-s", "1", "-m", "2"]);
        assert_eq!(
            stage_items(&err, "shadow-test").is_some(),
            lit,
            "{name}: {err}"
        );
        let traced = stage_items(&err, "intersect").unwrap();
        assert_eq!(traced > 400 * 300, lit, "{name}: {err}");
        let emitters = if lit { "1 point light" } else { "none" };
        assert!(err.contains(&format!("; emitters: {emitters}\n")), "{err}");
    }
    // The fixture's light is a point light, exact with one sample: `-l`
    // (samples per area-like light) leaves its shadow rays alone.
    let point_light_rays = |l: &str| {
        let args = ["-q", "--stats", "-s", "1", "-m", "2", "-l", l];
        let (_, err) = render_text("stages-point", lit, &args);
        stage_items(&err, "shadow-test")
    };
    assert_eq!(point_light_rays("4"), point_light_rays("1"));
    // -H counts a light of colour 0 in its N, as the reference does: one
    // black light beside the box's area light doubles the probes. Where
    // every light is a point light, no probe can find one: none is sent.
    let with_dark = |text: &str| {
        text.replace(
            "</library_lights>",
            "<light id=\"dark\"><technique_common><point><color>0 0 0</color>\
             </point></technique_common></light></library_lights>",
        )
        .replace(
            "</visual_scene>",
            "<node id=\"dark-node\"><instance_light url=\"#dark\"/></node></visual_scene>",
        )
    };
    let fixture_probes = |name: &str, text: &str| {
        let args = ["-q", "--stats", "-s", "1", "-m", "1", "-H"];
        stage_items(&render_text(name, text, &args).1, "probe (-H)")
    };
    let box_text = std::fs::read_to_string(cornell).unwrap();
    let box_probes = fixture_probes("stages-box", &box_text).unwrap();
    let err = render_text("stages-box-dark", &with_dark(&box_text), &["-q", "--stats"]).1;
    assert!(
        err.contains("; emitters: 1 area light, 1 light of colour 0\n"),
        "{err}"
    );
    assert_eq!(
        fixture_probes("stages-box-dark", &with_dark(&box_text)),
        Some(2 * box_probes)
    );
    assert_eq!(fixture_probes("stages-lamp", lit), None);
    assert_eq!(fixture_probes("stages-lamp-dark", &with_dark(lit)), None);
    // Nor does a path go on there: what it would meet, -H cannot see.
    let args = ["-q", "--stats", "-s", "1", "-m", "3", "-H"];
    let err = render_text("stages-lamp-deep", lit, &args).1;
    assert_eq!(stage_items(&err, "intersect"), Some(400 * 300), "{err}");
}

/// `--shading bvh-cost` maps each pixel's traversal steps to the rate
/// colours, and `--stats` counts them: without a tree every ray tests every
/// triangle (so every pixel costs the same), with one it tests a handful
/// and the cost varies across the image.
#[test]
fn bvh_cost_view_and_traversal_counters() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/torus_knot.dae");
    let per_ray = |line: &str, what: &str| -> f64 {
        let field = line
            .split(',')
            .find(|f| f.contains(what))
            .unwrap_or_else(|| panic!("no {what} in {line}"));
        field.split_whitespace().next().unwrap().parse().unwrap()
    };
    for accel in ["none", "median", "sah"] {
        let out = scratch(&format!("cost-{accel}.exr"));
        let args = [
            "-q", "--stats", "-s", "1", "-r", "64", "48", "--accel", accel,
        ];
        let o = render_to(
            scene,
            &out,
            &[&args[..], &["--shading", "bvh-cost"]].concat(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        let triangles: f64 = err
            .lines()
            .find_map(|l| l.strip_prefix("scene: "))
            .and_then(|l| l.split_whitespace().next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no scene line: {err}"));
        let traversal = err
            .lines()
            .find(|l| l.starts_with("traversal:"))
            .unwrap_or_else(|| panic!("no traversal line: {err}"));
        let tree = match accel {
            "none" => "bvh: none (no tree: every ray tests every primitive; ",
            _ => " wide nodes, depth ",
        };
        assert!(err.contains(tree), "{accel}: {err}");
        let (nodes, prims) = (
            per_ray(traversal, "nodes visited/ray"),
            per_ray(traversal, "primitives tested/ray"),
        );
        let image = read_image(&out).unwrap();
        let first = image.pixels[0];
        let uniform = image.pixels.iter().all(|p| *p == first);
        assert!(image.pixels.iter().all(|p| p.is_finite()));
        if accel == "none" {
            assert_eq!((nodes, prims), (0.0, triangles), "{traversal}");
            assert!(uniform, "every ray costs the same without a tree");
        } else {
            assert!(
                nodes >= 1.0 && prims < 0.01 * triangles,
                "{accel}: {traversal}"
            );
            assert!(!uniform, "{accel}: the heat map shows no variation");
        }
    }
}

/// Materials the integrator does not render yet are shaded as diffuse
/// with one warning per kind in use, however many materials of that kind.
#[test]
fn unrendered_materials_warn_once_per_kind() {
    let mirror = "<extra><technique profile=\"CGL\"><mirror><reflectance>1 1 1</reflectance></mirror></technique></extra>";
    let glass = "<extra><technique profile=\"CGL\"><glass><reflectance>1 1 1</reflectance><transmittance>1 1 1</transmittance><roughness>0</roughness><ior>1.5</ior></glass></technique></extra>";
    let base = include_str!("fixtures/minimal.dae");
    // The fixture's one effect (the triangle's) becomes a mirror; a second
    // mirror and a glass are added for the sphere to use.
    let effects = format!(
        "</profile_COMMON>\n      {mirror}\n    </effect>\n    \
         <effect id=\"fx2\"><profile_COMMON/>{mirror}</effect>\n    \
         <effect id=\"fx3\"><profile_COMMON/>{glass}</effect>"
    );
    let text = base
        .replacen("</profile_COMMON>\n    </effect>", &effects, 1)
        .replacen(
            "</library_materials>",
            "<material id=\"mat2\"><instance_effect url=\"#fx2\"/></material>\
             <material id=\"mat3\"><instance_effect url=\"#fx3\"/></material></library_materials>",
            1,
        );
    assert!(
        text.contains("fx3") && text.contains("ball-sym\" target=\"#mat\""),
        "the fixture changed"
    );
    // The sphere as the second mirror, then as glass.
    for (sphere, glass_warnings) in [("#mat2", 0), ("#mat3", 1)] {
        let bound = format!("ball-sym\" target=\"{sphere}\"");
        let text = text.replacen("ball-sym\" target=\"#mat\"", &bound, 1);
        let (_, err) = render_text("fallbacks", &text, &["-q", "-s", "1"]);
        let count = |kind: &str| {
            err.lines()
                .filter(|l| l.starts_with("warning:") && l.contains(&format!("{kind} materials")))
                .count()
        };
        assert_eq!(count("mirror"), 1, "sphere {sphere}: {err}");
        assert_eq!(count("glass"), glass_warnings, "sphere {sphere}: {err}");
        // Named with the scene file, and each material keeps its own
        // reflectance (the warning names the first one's).
        assert!(err.contains(".dae: mirror materials"), "{err}");
        assert!(
            err.contains("shading each as diffuse with its reflectance as albedo"),
            "{err}"
        );
    }
}

/// An adaptive render's sample counts: the EXR's `samples` channel holds
/// each pixel's count (whole batches, summing to the camera rays `--stats`
/// reports), and `<name>_rate.png` codes count/`-s` as the reference does:
/// blue at 0, green at ½, red at 1, linear, each channel trunc(255·c).
#[test]
fn adaptive_sample_counts_reach_the_exr_and_the_rate_image() {
    let exr = scratch("counts.exr");
    let _ = scratch("counts_rate.png"); // no leftover from an earlier run
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let spp = 64u32;
    let o = render_to(
        scene,
        &exr,
        &[
            "-q", "--stats", "-s", "64", "-a", "4", "0.3", "-m", "1", "-r", "32", "24",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let image = read_image(&exr).unwrap();
    let counts = &image.samples;
    assert_eq!(counts.len(), 32 * 24);
    assert!(
        counts
            .iter()
            .all(|&n| (4..=spp).contains(&n) && n.is_multiple_of(4))
    );
    // No pixel took all of -s, so coding by the image's own maximum (a
    // rate of 1 for its largest count) would show here.
    let most = *counts.iter().max().unwrap();
    assert!(
        most < spp && counts.iter().any(|&n| n < most),
        "counts up to {most}"
    );
    let total: u64 = counts.iter().map(|&n| n as u64).sum();
    assert_eq!(stage_items(&stderr(&o), "generate"), Some(total));

    let rate = image::open(scratch_path("counts_rate.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(rate.dimensions(), (32, 24));
    for (i, px) in rate.pixels().enumerate() {
        let r = counts[i] as f64 / spp as f64;
        let colour = if r <= 0.5 {
            let blue = (0.5 - r) / 0.5;
            [0.0, 1.0 - blue, blue]
        } else {
            let green = (1.0 - r) / 0.5;
            [1.0 - green, green, 0.0]
        };
        // Counts are multiples of 4 of 64, so 255·c = 31.875·m for whole
        // m: 0 or 255 exactly, else 1/8 to 7/8 past an integer, where
        // truncating and rounding often differ. Compared exactly.
        let want = colour.map(|c| (255.0 * c) as u8);
        assert_eq!(px.0, want, "pixel {i}: {} samples", counts[i]);
    }
}

/// The three `--accel` modes answer every query alike, so a path-traced
/// render (closest hits, shadow rays, camera-ray packets) is the same file
/// whichever builds the tree, or none does.
#[test]
fn every_accel_mode_renders_the_same_image() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/torus_knot.dae");
    let files: Vec<Vec<u8>> = ["none", "median", "sah"]
        .iter()
        .map(|accel| {
            let out = scratch(&format!("accel-{accel}.exr"));
            let args = [
                "-q", "-s", "4", "-m", "3", "-r", "64", "48", "--accel", accel,
            ];
            let o = render_to(scene, &out, &args);
            assert!(o.status.success(), "{}", stderr(&o));
            std::fs::read(&out).unwrap()
        })
        .collect();
    assert!(files[0] == files[1] && files[1] == files[2]);
}

/// `-p X Y DX DY` renders the reference's cell: columns X..X+DX and rows
/// Y..Y+DY counted from the bottom, written as a DX×DY image whose pixels
/// are bit for bit those of the same pixels in a whole render (each pixel
/// draws the same random numbers either way). A cell that does not fit
/// the image is refused, naming it.
#[test]
fn region_renders_the_cell_as_the_whole_image_has_it() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let render = |name: &str, extra: &[&str]| -> Output {
        let base = [
            "-q", "-s", "8", "-m", "3", "-a", "4", "0.2", "-r", "64", "48",
        ];
        render_to(scene, &scratch(name), &[&base[..], extra].concat())
    };
    let o = render("region-whole.exr", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render("region-cell.exr", &["-p", "10", "5", "20", "12"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let whole = read_image(&scratch_path("region-whole.exr")).unwrap();
    let cell = read_image(&scratch_path("region-cell.exr")).unwrap();
    assert_eq!((cell.width, cell.height), (20, 12));
    // Rows 5..17 from the bottom of 48 are rows 31..43 from the top.
    for y in 0..12 {
        for x in 0..20 {
            let (i, j) = ((y * 20 + x) as usize, ((31 + y) * 64 + 10 + x) as usize);
            assert_eq!(
                cell.pixels[i].to_array(),
                whole.pixels[j].to_array(),
                "({x}, {y})"
            );
            assert_eq!(cell.samples[i], whole.samples[j], "({x}, {y})");
        }
    }
    let rate = image::open(scratch_path("region-cell_rate.png")).unwrap();
    assert_eq!((rate.width(), rate.height()), (20, 12));

    for bad in [
        ["60", "5", "20", "12"],
        ["0", "40", "4", "9"],
        ["1", "1", "0", "3"],
    ] {
        let o = render("region-bad.exr", &["-p", bad[0], bad[1], bad[2], bad[3]]);
        assert_eq!(o.status.code(), Some(2), "-p {bad:?}");
        let err = stderr(&o);
        assert!(err.contains(&format!("-p {}", bad.join(" "))), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// `-c FILE` takes the view of a CS184 viewer's camera settings file, with
/// its vertical field of view whatever `-r` is (as the reference does): the
/// scene's own camera written as such a file for the render's size renders
/// the same image; another view renders another; a file of another aspect
/// ratio is warned about; a bad file is refused, naming it and the value
/// at fault.
#[test]
fn camera_settings_files_set_the_view() {
    use wavepath::scene::camera_file;
    let scene_path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let scene = wavepath::scene::collada::load_file(Path::new(scene_path)).unwrap();
    let render = |name: &str, extra: &[&str]| -> Output {
        let base = ["-q", "-s", "2", "-m", "1", "-r", "64", "48"];
        render_to(scene_path, &scratch(name), &[&base[..], extra].concat())
    };
    let own = scratch("own.cam");
    std::fs::write(&own, camera_file::write(&scene.camera, 64, 48)).unwrap();
    let mut moved = scene.camera.clone();
    moved.position += 0.3 * moved.camera_to_world.col(0);
    let other = scratch("moved.cam");
    std::fs::write(&other, camera_file::write(&moved, 64, 48)).unwrap();
    let mut files = Vec::new();
    for (name, extra) in [
        ("cam-none.exr", vec![]),
        ("cam-own.exr", vec!["-c", own.to_str().unwrap()]),
        ("cam-moved.exr", vec!["-c", other.to_str().unwrap()]),
    ] {
        let o = render(name, &extra);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(!stderr(&o).contains("warning"), "{name}: {}", stderr(&o));
        files.push(read_image(&scratch_path(name)).unwrap());
    }
    // The field of view goes through degrees in the file, so the rays may
    // differ in their last bits: the same image to within a trace.
    let diff = |a: &wavepath::film::Image, b: &wavepath::film::Image| -> f32 {
        let sum: f32 = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| (*p - *q).abs().max_element())
            .sum();
        sum / a.pixels.len() as f32
    };
    assert!(
        diff(&files[0], &files[1]) < 1e-3,
        "the scene's own camera, as a file, changed the image"
    );
    assert!(
        diff(&files[0], &files[2]) > 1e-2,
        "a moved camera rendered the same image"
    );

    // A file whose far clipping plane stops short of the scene: said,
    // naming the file; a scene camera's own far-plane warning gives way
    // to the file's camera (here one that sees everything).
    let mut short = scene.camera.clone();
    short.zfar = 0.5 * (short.position - short.target).length();
    let short_file = scratch("short.cam");
    std::fs::write(&short_file, camera_file::write(&short, 64, 48)).unwrap();
    let o = render("cam-short.exr", &["-c", short_file.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let says = format!(
        "warning: -c {}: the whole scene lies beyond the far clipping plane",
        short_file.display()
    );
    let err = stderr(&o);
    assert!(err.contains(&says), "{err}");
    assert!(err.contains("the file's fifth number"), "{err}");
    assert_eq!(err.matches("far clipping plane").count(), 1, "{err}");
    let far_scene = scratch_path("far-away.dae");
    let text = std::fs::read_to_string(scene_path).unwrap();
    let clipped = text.replace(">100</zfar>", ">0.2</zfar>");
    assert_ne!(clipped, text, "the built-in scene's zfar changed");
    std::fs::write(&far_scene, clipped).unwrap();
    let o = render_to(
        far_scene.to_str().unwrap(),
        &scratch("far.exr"),
        &["-q", "-r", "8", "6"],
    );
    assert!(
        stderr(&o).contains("beyond the far clipping plane"),
        "{}",
        stderr(&o)
    );
    let o = render_to(
        far_scene.to_str().unwrap(),
        &scratch("far-own.exr"),
        &["-q", "-r", "8", "6", "-c", own.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("far clipping plane"), "{}", stderr(&o));

    // Written for 800×600 and rendered square: said.
    let wide = scratch("wide.cam");
    std::fs::write(&wide, camera_file::write(&scene.camera, 800, 600)).unwrap();
    let o = render_to(
        scene_path,
        &scratch("cam-wide.exr"),
        &["-q", "-r", "48", "48", "-c", wide.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("would stretch"), "{}", stderr(&o));

    let bad = scratch("bad.cam");
    std::fs::write(&bad, "45 35 1.33 0.1 100\n0 0 nan 0 0 0\n").unwrap();
    let devices = std::path::PathBuf::from("/dev/zero");
    for (file, says) in [
        (&bad, "found 11"),
        (&scratch("missing.cam"), "cannot read"),
        (&scratch(""), "cannot read"),
        (&devices, "more than 64 KiB"),
    ] {
        if !file.exists() && file == &devices {
            continue;
        }
        let o = render("cam-bad.exr", &["-c", file.to_str().unwrap()]);
        assert!(!o.status.success());
        let err = stderr(&o);
        assert!(
            err.contains(&format!("-c {}", file.display())) && err.contains(says),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    // The camera file is read before the scene: with both at fault, the
    // error names the small file, found without loading the large one.
    let o = render_to(
        "no/such/scene.dae",
        &scratch("cam-bad-both.exr"),
        &["-q", "-c", bad.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains(&format!("-c {}", bad.display())), "{err}");
    assert!(!err.contains("no/such/scene.dae"), "{err}");
}

/// The rate image (and the EXR's `samples` channel) come with adaptive
/// sampling only: not with one sample per pixel, a tolerance of 0 (which
/// can never be met: fixed sampling, as the README says), `--no-adaptive`,
/// or a view that is not an estimate (nothing converges).
#[test]
fn a_rate_image_only_where_sampling_is_adaptive() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    for (name, args, adaptive) in [
        ("rate-on", &["-s", "8", "-a", "4", "0.5"][..], true),
        ("rate-one-spp", &["-s", "1", "-a", "4", "0.5"][..], false),
        ("rate-zero-tol", &["-s", "8", "-a", "4", "0"][..], false),
        ("rate-fixed", &["-s", "8", "--no-adaptive"][..], false),
        (
            "rate-normals",
            &["-s", "8", "--shading", "normals"][..],
            false,
        ),
        (
            "rate-cost",
            &["-s", "8", "--shading", "bvh-cost"][..],
            false,
        ),
    ] {
        let out = scratch(&format!("{name}.exr"));
        let _ = scratch(&format!("{name}_rate.png"));
        let o = render_to(scene, &out, &[&["-q", "-r", "16", "12"], args].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert_eq!(
            scratch_exists(&format!("{name}_rate.png")),
            adaptive,
            "{name}"
        );
        let image = read_image(&out).unwrap();
        assert_eq!(image.samples.iter().any(|&n| n > 0), adaptive, "{name}");
    }
}

/// Without `-q` a render ends with what it wrote (file, size, samples per
/// pixel on average) and its timings on stderr; with `-q`, with nothing.
#[test]
fn the_closing_report_says_what_was_written_unless_quiet() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    let out = scratch("report.png");
    let args = ["--no-adaptive", "-s", "3", "-r", "20", "10", "-t", "1"];
    let o = render_to(scene, &out, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let wrote = format!(
        "wrote {} (20x10, 3.0 samples/pixel on average)",
        out.display()
    );
    assert!(err.contains(&wrote), "{err}");
    assert!(
        err.contains("render ") && err.contains("on 1 thread |"),
        "{err}"
    );
    assert!(err.contains("Mrays/s"), "{err}");

    let o = render_to(scene, &out, &[&["-q"], &args[..]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "");

    // Adaptive: how many pixels stopped before -s, as the EXR counts them.
    let exr = scratch("report.exr");
    let _ = scratch("report_rate.png");
    let args = ["-s", "64", "-a", "16", "0.1", "-r", "20", "10", "-t", "2"];
    let o = render_to(scene, &exr, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let samples = read_image(&exr).unwrap().samples;
    let early = samples.iter().filter(|&&n| n < 64).count();
    let mean = samples.iter().sum::<u32>() as f64 / 200.0;
    assert!(
        early > 0 && early < 200,
        "the test wants some pixels to stop: {early}"
    );
    let wrote = format!(
        "wrote {} (20x10, {mean:.2} samples/pixel on average; {early} of 200 pixels stopped before 64)",
        exr.display()
    );
    assert!(stderr(&o).contains(&wrote), "{}", stderr(&o));
    assert!(stderr(&o).contains("on 2 threads |"), "{}", stderr(&o));
}

/// A write that fails after the render (a full disk: a link to Linux's
/// `/dev/full`, which takes no bytes) is an error naming the file, with
/// status 1 — for a PNG too, whose last buffered bytes are written only
/// when the file is flushed — and no "wrote" line.
#[test]
fn a_full_disk_is_an_error_for_every_output() {
    if !Path::new("/dev/full").exists() || !cfg!(unix) {
        println!("skipped: no /dev/full on this system");
        return;
    }
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");
    for name in ["full.png", "full.exr"] {
        let link = scratch(name);
        #[cfg(unix)]
        std::os::unix::fs::symlink("/dev/full", &link).unwrap();
        let o = render_to(scene, &link, &["-r", "8", "6"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        let says = format!("{}: cannot write", link.display());
        assert!(err.contains(&says), "{name}: {err}");
        assert!(err.contains("No space left on device"), "{name}: {err}");
        assert!(!err.contains("wrote "), "{name}: {err}");
        let _ = std::fs::remove_file(&link);
    }
    // The rate image of an adaptive render.
    let image = scratch("full-rate.png");
    let rate = scratch("full-rate_rate.png");
    #[cfg(unix)]
    std::os::unix::fs::symlink("/dev/full", &rate).unwrap();
    let o = render_to(
        scene,
        &image,
        &["-r", "8", "6", "-s", "8", "-a", "4", "0.05"],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("{}: cannot write PNG", rate.display())),
        "{err}"
    );
    let _ = std::fs::remove_file(&rate);
}
