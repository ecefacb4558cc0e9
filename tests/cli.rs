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
        vec!["-b", "-1", scene],
        vec!["-f", "out.jpg", scene],
        vec!["--shading", "wireframe", scene],
        vec!["-e", "sky.exr", scene],
        vec!["-p", "0", "0", "10", "10", scene],
        vec!["-r", "65536", "65536", scene],
        vec!["--roulette-depth", "-1", scene],
    ] {
        let o = wavepath(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(err.contains("--help"), "{args:?}: no usage hint: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
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
    // Far more work than the test waits for.
    let child = Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .args([
            "-q",
            "-s",
            "100000",
            "--no-adaptive",
            "-m",
            "5",
            "-r",
            "320",
            "240",
            "-f",
        ])
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
    assert!(stderr(&o).contains("interrupted"), "{}", stderr(&o));
    let image = read_image(&out).unwrap();
    assert!(image.pixels.iter().all(|p| p.is_finite()));
    assert!(
        image.pixels.iter().any(|p| p.max_element() > 0.0),
        "nothing was kept"
    );
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
    let o = wavepath(&[
        "-q",
        "--no-adaptive",
        "-s",
        "2",
        "-m",
        "3",
        "-r",
        "24",
        "18",
        "-f",
        out.to_str().unwrap(),
        scene.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("reflects more light than it receives"),
        "{err}"
    );
    assert!(err.contains("pixels are NaN or infinite"), "{err}");
    let image = read_image(&out).unwrap();
    assert!(image.pixels.iter().all(|p| p.is_finite()));
}

/// A scene that nothing lights renders what it emits — here nothing, so
/// black — exits 0 and says why, once; a light of colour 0 0 0 lights
/// nothing and is said to. Emission alone (`-m 0`) needs no light and
/// gets no warning, nor does a lit scene. (A W×H render is the central
/// crop of the 800×600 view, so it is large enough to take in the objects.)
#[test]
fn a_scene_without_light_warns_once_and_renders_black() {
    let lit = include_str!("fixtures/minimal.dae");
    let dark = lit.replace("<color>1 1 1</color>", "<color>0 0 0</color>");
    let unlit = lit.replace("<instance_light url=\"#lamp\"/>", "");
    assert!(dark != lit && unlit != lit, "the fixture changed");
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
        ("unlit-m0", unlit.as_str(), "0", None),
    ];
    for (name, text, depth, says) in cases {
        let scene = scratch(&format!("{name}.dae"));
        std::fs::write(&scene, text).unwrap();
        let out = scratch(&format!("{name}.exr"));
        let o = wavepath(&[
            "-q",
            "-s",
            "2",
            "-m",
            depth,
            "-r",
            "400",
            "300",
            "-f",
            out.to_str().unwrap(),
            scene.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let err = stderr(&o);
        let warnings: Vec<&str> = err
            .lines()
            .filter(|l| l.contains("only emission seen directly"))
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
                if depth != "0" {
                    assert!(brightest > 0.0, "{name}: the lit scene rendered black");
                }
            }
        }
    }
}
