//! `wavepath compare`, `converge` and `mitsuba` as a user runs them: results
//! on good input, one clear line naming the file and a non-zero exit on
//! bad input, and the render command left as it was.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use wavepath::film::output::read_image;

fn wavepath_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run wavepath")
}

fn wavepath(args: &[&str]) -> Output {
    wavepath_in(Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

/// A fresh scratch directory for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli_tools")
        .join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

const SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.dae");

/// Renders the Cornell box to `out` at `w`×`h`.
fn render(out: &Path, w: u32, h: u32, spp: u32, seed: u32) {
    let o = wavepath(&[
        "-q",
        "--no-adaptive",
        "-s",
        &spp.to_string(),
        "-m",
        "2",
        "-r",
        &w.to_string(),
        &h.to_string(),
        "--seed",
        &seed.to_string(),
        "-f",
        out.to_str().unwrap(),
        SCENE,
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

/// Asserts a refused flag value: status 2, the message `says`, the usage
/// line of `command` (the command refusing it, not another), and no panic.
fn assert_usage_error(o: &Output, command: &str, says: &str) {
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(says), "message does not say {says}: {err}");
    assert!(
        err.contains(&format!("Usage: wavepath {command} ")),
        "no usage line of wavepath {command}: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// Asserts a failure whose message names `file`, and no panic.
fn assert_refused(o: &Output, file: &str) {
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(file), "message does not name {file}: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn compare_reports_zero_for_identical_images_and_error_for_different_ones() {
    let dir = scratch("compare_metrics");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    render(&a, 32, 24, 4, 1);
    render(&b, 32, 24, 4, 2);
    let s = |p: &Path| p.to_str().unwrap().to_string();

    let o = wavepath(&["compare", &s(&a), &s(&a)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    let all = out.lines().find(|l| l.starts_with("all")).expect(&out);
    assert!(
        all.split_whitespace()
            .skip(1)
            .all(|v| v.parse::<f64>() == Ok(0.0)),
        "{all}"
    );

    let diff = dir.join("diff.png");
    let o = wavepath(&["compare", &s(&a), &s(&b), "--diff", &s(&diff)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    let all = out.lines().find(|l| l.starts_with("all")).expect(&out);
    let rel_mse: f64 = all.split_whitespace().nth(2).unwrap().parse().unwrap();
    // Two 4-spp renders with different seeds differ, but not wildly.
    assert!(rel_mse > 1e-4 && rel_mse < 10.0, "{out}");
    assert!(out.contains("red >="), "the diff's scale is printed: {out}");
    let d = read_image(&diff).unwrap();
    assert_eq!((d.width, d.height), (32, 24));
}

#[test]
fn compare_refuses_bad_input_naming_the_file() {
    let dir = scratch("compare_bad");
    let good = dir.join("good.exr");
    render(&good, 16, 12, 1, 0);
    let small = dir.join("small.png");
    render(&small, 8, 6, 1, 0);
    let txt = dir.join("notes.txt");
    std::fs::write(&txt, "hello").unwrap();
    let junk = dir.join("junk.exr");
    std::fs::write(&junk, "not an exr").unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();

    let missing = dir.join("missing.exr");
    assert_refused(
        &wavepath(&["compare", &s(&missing), &s(&good)]),
        "missing.exr",
    );
    assert_refused(
        &wavepath(&["compare", &s(&good), &s(&missing)]),
        "missing.exr",
    );
    assert_refused(&wavepath(&["compare", &s(&txt), &s(&good)]), "notes.txt");
    // A file named .exr that is not one is called that; a real EXR cut
    // short keeps the decoder's own complaint.
    let o = wavepath(&["compare", &s(&junk), &s(&good)]);
    assert_refused(&o, "junk.exr: not an OpenEXR file");
    let cut = dir.join("cut.exr");
    std::fs::write(&cut, &std::fs::read(&good).unwrap()[..40]).unwrap();
    let o = wavepath(&["compare", &s(&cut), &s(&good)]);
    assert_refused(&o, "cut.exr: cannot read EXR");
    let o = wavepath(&["compare", &s(&small), &s(&good)]);
    assert_refused(&o, "small.png");
    assert!(text(&o.stderr).contains("good.exr"));
    // Standard errors that are not numbers a variance can be made of: the
    // file written channel by channel, as wavepath never writes them.
    for (name, bad) in [("nan", f32::NAN), ("negative", -1.0), ("huge", 3e38)] {
        use exr::prelude::*;
        let n = 16 * 12;
        let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
        for c in ["B", "G", "R"] {
            channels.push(AnyChannel::new(c, FlatSamples::F32(vec![0.5; n])));
        }
        channels.push(AnyChannel::new("samples", FlatSamples::F32(vec![8.0; n])));
        for c in ["stderr.R", "stderr.G", "stderr.B"] {
            let mut se = vec![0.01; n];
            if c == "stderr.G" {
                se[16 + 2] = bad;
            }
            channels.push(AnyChannel::new(c, FlatSamples::F32(se)));
        }
        let layer = Layer::new(
            (16, 12),
            LayerAttributes::default(),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(channels),
        );
        let path = dir.join(format!("stderr_{name}.exr"));
        Image::from_layer(layer).write().to_file(&path).unwrap();
        let o = wavepath(&["compare", &s(&good), &s(&path)]);
        assert_refused(
            &o,
            &format!("stderr_{name}.exr: channel stderr.G at pixel (2, 1) is "),
        );
    }
    // A usage error is clap's: status 2, with the usage line.
    let o = wavepath(&["compare", &s(&good)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("wavepath compare"));

    // A header that claims 100000×100000 pixels (40 GB to decode) in a
    // file of a few hundred bytes: refused from the header.
    let mut bytes = std::fs::read(&good).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
    for (k, v) in [(8, 99_999i32), (12, 99_999)] {
        bytes[at + k..at + k + 4].copy_from_slice(&v.to_le_bytes());
    }
    let huge = dir.join("huge.exr");
    std::fs::write(&huge, &bytes).unwrap();
    let o = wavepath(&["compare", &s(&huge), &s(&good)]);
    assert_refused(&o, "huge.exr");
    assert!(
        text(&o.stderr).contains("100000x100000"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn compare_goes_quietly_when_its_reader_stops_reading() {
    // `wavepath compare a b | head -1`: the pipe closes before the report
    // is written, which must not be a panic.
    let dir = scratch("compare_pipe");
    let image = dir.join("a.exr");
    render(&image, 16, 12, 1, 0);
    let path = image.to_str().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .args(["compare", path, path])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let err = text(&o.stderr);
    assert!(o.status.success(), "{:?}: {err}", o.status);
    assert!(!err.contains("panicked"), "{err}");
}

/// converge's one-sample budget and a reference's one-sample replicates
/// take a random point of each pixel, as the reference averages over each
/// pixel, not the pixel's centre (which a render of one sample per pixel
/// takes, and which would measure a fixed bias besides the noise). At
/// `-m 0` nothing else is random: the one-sample error changes with the
/// seed, and replicates differ, only if the points do.
#[test]
fn converges_one_sample_budget_is_a_random_point_of_each_pixel() {
    let dir = scratch("converge_one_sample");
    // The whole box at 480×360 (smaller images crop its middle): the
    // light's edges cross pixels.
    let common = ["-m", "0", "-r", "480", "360"];
    // Eight replicates of one sample each: were they pixel centres, all
    // would be the same image and their spread 0.
    let reference = [
        &["--make-reference", "-s", "8", "--ref", "r.exr"],
        &common[..],
    ]
    .concat();
    let (out, _) = converge(&dir, &reference);
    assert!(own_rel_mse(&out, 8) > 0.0, "{out}");
    let one_sample = |seed: &str, csv: &str| {
        let args = [
            &[
                "--max-spp",
                "1",
                "--ref",
                "r.exr",
                "--seed",
                seed,
                "--csv",
                csv,
            ][..],
            &common[..],
        ]
        .concat();
        converge(&dir, &args);
        let rows = csv_rows(&dir.join(csv));
        assert_eq!(rows.len(), 1);
        rows[0].3
    };
    let (a, b) = (one_sample("1", "a.csv"), one_sample("2", "b.csv"));
    assert!(a > 0.0 && a != b, "{a} {b}");
}

/// Ctrl-C while a reference renders keeps the replicates finished: two or
/// more make a reference of fewer samples (its own error measured as
/// usual), written before the exit status of an interrupt; fewer make
/// none. Each finished replicate is reported, which is when the test
/// presses Ctrl-C.
#[test]
#[cfg(unix)]
fn an_interrupted_reference_keeps_the_replicates_finished() {
    use std::io::{BufRead, BufReader, Read};
    let dir = scratch("converge_interrupted");
    // Ctrl-C once stderr has said `when`; returns the exit status, stderr
    // and stdout. 8 replicates of 128 samples at -m 5: each takes a good
    // fraction of a second, far more than a signal takes to arrive.
    let interrupt = |when: &str, name: &str| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_wavepath"))
            .current_dir(&dir)
            .args([
                "converge",
                "--make-reference",
                "-s",
                "1024",
                "-m",
                "5",
                "-r",
                "160",
                "120",
                "-t",
                "1",
                "--ref",
                name,
                SCENE,
            ])
            .stderr(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let mut err = BufReader::new(child.stderr.take().unwrap());
        let mut said = String::new();
        while !said.contains(when) {
            let before = said.len();
            err.read_line(&mut said).unwrap();
            assert!(said.len() > before, "stderr ended: {said}");
        }
        let killed = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        err.read_to_string(&mut said).unwrap();
        let o = child.wait_with_output().unwrap();
        (o.status.code(), said, text(&o.stdout))
    };

    let (status, err, out) = interrupt("replicate 2 of 8 done", "r.exr");
    assert_eq!(status, Some(130), "{err}");
    let kept = err
        .split("interrupted: the reference holds the ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|k| k.parse::<u32>().ok())
        .unwrap_or_else(|| panic!("no kept replicates said: {err}"));
    assert!((2..8).contains(&kept), "{err}");
    assert!(own_rel_mse(&out, kept) > 0.0, "{out}");
    let reference = read_image(&dir.join("r.exr")).unwrap();
    assert!(reference.samples.iter().all(|&n| n == 128 * kept));

    let (status, err, _) = interrupt("rendering the reference", "none.exr");
    assert_eq!(status, Some(130), "{err}");
    assert!(
        err.contains("interrupted: no reference written (0 of 8 replicates finished"),
        "{err}"
    );
    assert!(!dir.join("none.exr").exists());
}

/// A measurement whose every error is 0 (at `-m 0` the middle of the box
/// that a small image shows emits nothing: every render is black, as is
/// the reference) writes its CSV and says why there is no plot, instead of
/// failing after the renders.
#[test]
fn converge_without_an_error_to_plot_writes_the_csv_and_says_so() {
    let dir = scratch("converge_black");
    let common = ["-m", "0", "-r", "24", "18"];
    converge(
        &dir,
        &[
            &["--make-reference", "-s", "2", "--ref", "r.exr"],
            &common[..],
        ]
        .concat(),
    );
    let (_, err) = converge(
        &dir,
        &[
            &["--max-spp", "2", "--ref", "r.exr", "--csv", "c.csv"],
            &common[..],
        ]
        .concat(),
    );
    let rows = csv_rows(&dir.join("c.csv"));
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|r| r.3 == 0.0), "{rows:?}");
    assert!(
        err.contains("c.svg not written: no budget has a positive error"),
        "{err}"
    );
    assert!(!dir.join("c.svg").exists());
}

#[test]
fn converge_makes_a_reference_with_its_noise_and_writes_csv_and_plot() {
    let dir = scratch("converge");
    let common = ["-m", "2", "-r", "24", "18"];
    let mut args = vec!["converge", "--make-reference", "-s", "64"];
    args.extend(common);
    args.extend(["--ref", "ref.exr", SCENE]);
    let o = wavepath_in(&dir, &args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("own relMSE"),
        "{}",
        text(&o.stdout)
    );
    let reference = read_image(&dir.join("ref.exr")).unwrap();
    assert_eq!((reference.width, reference.height), (24, 18));
    assert!(reference.samples.iter().all(|&n| n == 64));
    assert!(reference.variance.iter().any(|v| v.max_element() > 0.0));

    let mut args = vec!["converge", "--max-spp", "4"];
    args.extend(common);
    args.extend([
        "--ref",
        "ref.exr",
        "--estimators",
        "hemisphere,light",
        "--csv",
        "c.csv",
        SCENE,
    ]);
    let o = wavepath_in(&dir, &args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let csv = std::fs::read_to_string(dir.join("c.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let got: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    assert_eq!(
        got,
        [
            ("hemisphere", "1"),
            ("hemisphere", "2"),
            ("hemisphere", "4"),
            ("light", "1"),
            ("light", "2"),
            ("light", "4")
        ]
    );
    let rel: Vec<f64> = rows.iter().map(|r| r[3].parse().unwrap()).collect();
    // Light sampling beats uniform hemisphere sampling at equal spp on the
    // Cornell box by a wide margin; error falls as spp grows.
    assert!(rel[5] < rel[2] && rel[5] < rel[3], "{csv}");
    let svg = std::fs::read_to_string(dir.join("c.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("hemisphere"),
        "{svg}"
    );

    // Plot-only mode: curves from CSV files, named by file and estimator.
    let o = wavepath_in(
        &dir,
        &["converge", "--plot-csv", "c.csv", "--plot", "again.svg"],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let svg = std::fs::read_to_string(dir.join("again.svg")).unwrap();
    assert!(
        svg.contains("c hemisphere") && svg.contains("c light"),
        "{svg}"
    );
    let o = wavepath_in(
        &dir,
        &["converge", "--plot-csv", "none.csv", "--plot", "x.svg"],
    );
    assert_refused(&o, "none.csv");
}

/// A reference records what decides its expected image (scene and camera
/// files, -m, --bounces, the lens); measuring against one that shows
/// another image is refused, while settings that change only the noise
/// (estimator, -l, seed) may differ.
#[test]
fn converge_refuses_a_reference_of_another_image() {
    let dir = scratch("converge_expectation");
    let point_light = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/point_light.dae");
    // The scene's camera moved one unit along x, as a -c file, and the
    // same file laid out differently.
    let mut camera = wavepath::scene::collada::load_file(Path::new(SCENE))
        .unwrap()
        .camera;
    camera.position.x += 1.0;
    let moved = wavepath::scene::camera_file::write(&camera, 8, 6);
    std::fs::write(dir.join("moved.txt"), &moved).unwrap();
    std::fs::write(dir.join("moved_again.txt"), moved.replace(' ', "\n  ")).unwrap();
    let make = [
        "converge",
        "-q",
        "--make-reference",
        "-s",
        "4",
        "-m",
        "2",
        "-r",
        "8",
        "6",
    ];
    let reference = dir.join("ref.exr");
    let mut made = Vec::new();
    for _ in 0..2 {
        let o = wavepath_in(&dir, &[&make[..], &["--ref", "ref.exr", SCENE]].concat());
        assert!(o.status.success(), "{}", text(&o.stderr));
        made.push(std::fs::read(&reference).unwrap());
    }
    assert!(made[0] == made[1], "the same reference, different bytes");

    let measure = |flags: &[&str], scene: &str| {
        let base = [
            "converge",
            "-q",
            "-r",
            "8",
            "6",
            "--max-spp",
            "1",
            "--ref",
            "ref.exr",
        ];
        wavepath_in(&dir, &[&base[..], flags, &[scene]].concat())
    };
    for (flags, scene, says) in [
        (&["-m", "3"][..], SCENE, "-m 2 where these renders use -m 3"),
        (&["-m", "2"], point_light, "another scene file"),
        (
            &["-m", "2", "--bounces", "last"],
            SCENE,
            "--bounces accumulate where",
        ),
        (
            &["-m", "2", "-b", "0.1"],
            SCENE,
            "-b 0 where these renders use -b 0.1",
        ),
        (&["-m", "2", "-c", "moved.txt"], SCENE, "another camera"),
    ] {
        let o = measure(flags, scene);
        assert_refused(&o, "ref.exr");
        let err = text(&o.stderr);
        assert!(
            err.contains("shows another image") && err.contains(says),
            "{flags:?}: {err}"
        );
        assert!(!dir.join("converge.csv").exists(), "{flags:?}");
    }
    // What changes only the noise may differ, and so may the spelling of
    // a value or a file.
    for flags in [
        &["-m", "2", "-H", "-l", "3", "--seed", "7", "--no-roulette"][..],
        &["-m", "2", "-b", "-0"],
    ] {
        let o = measure(flags, SCENE);
        assert!(o.status.success(), "{flags:?}: {}", text(&o.stderr));
    }
    let make_with = |flags: &[&str], scene: &str| {
        let o = wavepath_in(
            &dir,
            &[&make[..], flags, &["--ref", "ref.exr", scene]].concat(),
        );
        assert!(o.status.success(), "{}", text(&o.stderr));
    };
    make_with(&["-c", "moved.txt"], SCENE);
    let o = measure(&["-m", "2", "-c", "moved_again.txt"], SCENE);
    assert!(o.status.success(), "{}", text(&o.stderr));

    // The focal distance counts only with a lens.
    make_with(&["-b", "0.1", "-d", "3"], SCENE);
    let o = measure(&["-m", "2", "-b", "0.1", "-d", "4"], SCENE);
    assert_refused(&o, "ref.exr");
    let err = text(&o.stderr);
    assert!(err.contains("-d 3 where these renders use -d 4"), "{err}");
    make_with(&[], SCENE);
    let o = measure(&["-m", "2", "-d", "2"], SCENE);
    assert!(o.status.success(), "{}", text(&o.stderr));

    // With a point light, -H is another image: it misses that light.
    make_with(&[], point_light);
    let o = measure(&["-m", "2", "-l", "2"], point_light);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = measure(&["-m", "2", "-H"], point_light);
    assert_refused(&o, "ref.exr");
    let err = text(&o.stderr);
    assert!(err.contains("which -H leaves out here"), "{err}");
    // And it says why, before anything else.
    assert!(
        err.starts_with(
            "warning: hemisphere estimator: uniform hemisphere sampling (-H) never finds"
        ),
        "{err}"
    );
    make_with(&["-H"], point_light);
    let o = measure(&["-m", "2"], point_light);
    assert_refused(&o, "ref.exr");
    let err = text(&o.stderr);
    assert!(
        err.contains("without the point and directional lights' light"),
        "{err}"
    );

    // A reference from elsewhere records nothing: taken on trust, said so.
    // Said once, however many estimators are measured.
    render(&reference, 8, 6, 4, 0);
    let o = measure(&["-m", "3", "--estimators", "hemisphere,light"], SCENE);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(
        text(&o.stderr).matches("records no settings").count(),
        1,
        "{}",
        text(&o.stderr)
    );
}

/// Makes a 48×36, `-m 2` reference of the Cornell box in `dir`; returns
/// what converge printed.
fn small_reference(dir: &Path, spp: &str, seed: &str, name: &str) -> String {
    let args = [
        "--make-reference",
        "-s",
        spp,
        "-m",
        "2",
        "-r",
        "48",
        "36",
        "--seed",
        seed,
        "--ref",
        name,
    ];
    converge(dir, &args).0
}

/// A reference's own relMSE, measured from its replicates, is what two
/// independent references actually differ by: the relMSE between them is
/// the sum of their own, in expectation. (The s²/n of each pixel's
/// stratified samples overstated it several times on such an image.)
#[test]
fn a_references_own_error_is_what_two_references_differ_by() {
    let dir = scratch("converge_own_error");
    let own: Vec<f64> = ["0", "1"]
        .iter()
        .map(|seed| {
            let out = small_reference(&dir, "256", seed, &format!("ref{seed}.exr"));
            own_rel_mse(&out, 8)
        })
        .collect();
    let o = wavepath_in(&dir, &["compare", "ref0.exr", "ref1.exr"]);
    let report = text(&o.stdout);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let between: f64 = report
        .lines()
        .find(|l| l.starts_with("all"))
        .and_then(|l| l.split_whitespace().nth(2))
        .and_then(|v| v.parse().ok())
        .expect(&report);
    // The estimates average 5,184 values' spreads of eight means, and the
    // difference 5,184 squares: each within a few per cent; ±25% is many
    // standard deviations, and the old estimate was off by 3–10×.
    let ratio = between / (own[0] + own[1]);
    assert!(
        (0.8..1.25).contains(&ratio),
        "{between} vs {own:?}: {ratio}"
    );
    assert!(
        report.contains("measured from its independent replicates"),
        "{report}"
    );
}

/// A reference of few samples estimates the same image as one of many:
/// its replicates' samples, however few, are spread over each pixel (a
/// render of one sample per pixel otherwise takes the pixel's centre,
/// another image). Eight samples a pixel are too few for the per-pixel
/// test on each file's own variance (compare warns, naming the file); the
/// two files come from one estimator, so the test may take each pixel's
/// larger variance estimate (the reference's), and that still tells
/// another image (one bounce fewer) apart.
#[test]
fn a_reference_of_few_samples_estimates_the_same_image() {
    let dir = scratch("converge_few_samples");
    for (spp, seed, name) in [("8", "0", "few.exr"), ("256", "1", "many.exr")] {
        small_reference(&dir, spp, seed, name);
    }
    let other = [
        "--make-reference",
        "-s",
        "8",
        "-m",
        "1",
        "-r",
        "48",
        "36",
        "--ref",
        "other.exr",
    ];
    converge(&dir, &other);
    let compare = |flags: &[&str], image: &str| {
        let o = wavepath_in(&dir, &[&["compare"], flags, &[image, "many.exr"]].concat());
        assert!(o.status.success(), "{}", text(&o.stderr));
        (text(&o.stdout), text(&o.stderr))
    };
    let (_, err) = compare(&[], "few.exr");
    assert!(
        err.contains("few.exr: some pixels hold only 8 samples, too few"),
        "{err}"
    );
    assert!(!err.contains("many.exr"), "{err}");
    let (report, err) = compare(&["--same-estimator"], "few.exr");
    assert!(report.contains(": consistent"), "{report}");
    assert_eq!(err, "");
    let (report, _) = compare(&["--same-estimator"], "other.exr");
    assert!(report.contains(": DIFFERENT"), "{report}");
}

#[test]
fn converge_refuses_bad_references_naming_the_file() {
    let dir = scratch("converge_bad");
    let o = wavepath_in(
        &dir,
        &["converge", "-r", "8", "6", "--ref", "none.exr", SCENE],
    );
    assert_refused(&o, "none.exr");
    let o = wavepath_in(
        &dir,
        &["converge", "-r", "8", "6", "--ref", "ref.png", SCENE],
    );
    assert_usage_error(
        &o,
        "converge",
        "--ref ref.png: the reference must be an .exr file",
    );
    render(&dir.join("big.exr"), 16, 12, 1, 0);
    let o = wavepath_in(
        &dir,
        &["converge", "-r", "8", "6", "--ref", "big.exr", SCENE],
    );
    assert_refused(&o, "big.exr");
    // A reference with a NaN pixel (written by another program: wavepath
    // writes none) would make every error NaN.
    let (w, h) = (8usize, 6usize);
    exr::prelude::write_rgb_file(dir.join("nan.exr"), w, h, |x, y| {
        let g = if (x, y) == (5, 0) { f32::NAN } else { 0.5 };
        (0.5, g, 0.5)
    })
    .unwrap();
    let o = wavepath_in(
        &dir,
        &[
            "converge",
            "-r",
            &w.to_string(),
            &h.to_string(),
            "--ref",
            "nan.exr",
            SCENE,
        ],
    );
    assert_refused(&o, "nan.exr");
    assert!(text(&o.stderr).contains("NaN"));
    // The plot is SVG whatever its name says; a .png name is refused
    // before anything is rendered.
    let o = wavepath_in(
        &dir,
        &[
            "converge", "-r", "16", "12", "--ref", "big.exr", "--plot", "plot.png", SCENE,
        ],
    );
    assert_usage_error(
        &o,
        "converge",
        "--plot plot.png: the plot is written as SVG",
    );
    assert!(!dir.join("plot.png").exists());
}

#[test]
fn a_scene_named_like_a_tool_renders_when_given_as_a_path() {
    let dir = scratch("named_compare");
    std::fs::copy(SCENE, dir.join("compare")).unwrap();
    let o = wavepath_in(&dir, &["-q", "-r", "8", "6", "-f", "out.png", "./compare"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(dir.join("out.png").is_file());
}

/// `compare` decodes PNGs with the curve they were written with: our PNG
/// of a render against the EXR of the same render differs only by 8-bit
/// quantisation (and clipping of the light), unless decoded as sRGB.
#[test]
fn compare_decodes_our_pngs_with_the_reference_curve() {
    let dir = scratch("compare_tonemap");
    let (png, exr) = (dir.join("a.png"), dir.join("a.exr"));
    render(&png, 160, 120, 2, 3);
    render(&exr, 160, 120, 2, 3);
    let mape = |extra: &[&str]| -> f64 {
        let mut args = vec!["compare"];
        args.extend_from_slice(extra);
        args.extend([png.to_str().unwrap(), exr.to_str().unwrap()]);
        let o = wavepath(&args);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let out = text(&o.stdout);
        let all = out
            .lines()
            .find(|l| l.starts_with("all"))
            .expect("an 'all' row");
        all.split_whitespace().nth(3).unwrap().parse().unwrap()
    };
    let reference = mape(&[]);
    let srgb = mape(&["--tonemap", "srgb"]);
    assert!(
        reference < 3.0,
        "MAPE {reference}% decoding with the reference curve"
    );
    assert!(srgb > 10.0, "MAPE {srgb}% should show the wrong curve");
}

#[test]
fn mitsuba_writes_the_scene_and_refuses_bad_input_naming_the_file() {
    let dir = scratch("mitsuba");
    let out = dir.join("cornell_mitsuba");
    let o = wavepath(&[
        "mitsuba",
        "-s",
        "32",
        "-m",
        "3",
        "-r",
        "200",
        "150",
        SCENE,
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let xml = std::fs::read_to_string(out.join("scene.xml")).unwrap();
    // Roulette starts where wavepath's does unless --rr-depth says
    // otherwise (Mitsuba counts depth from 1).
    let rr_depth = wavepath::integrator::ROULETTE_DEPTH + 1;
    for expected in [
        &format!("name=\"rr_depth\" value=\"{rr_depth}\""),
        "name=\"max_depth\" value=\"4\"",
        "name=\"sample_count\" value=\"32\"",
        "name=\"width\" value=\"200\"",
        "name=\"height\" value=\"150\"",
        "<emitter type=\"area\">",
    ] {
        assert!(xml.contains(expected), "{expected} missing from\n{xml}");
    }
    // Every mesh the XML names was written.
    for file in xml.split("value=\"meshes/").skip(1) {
        let name = &file[..file.find('"').unwrap()];
        assert!(out.join("meshes").join(name).is_file(), "{name}");
    }

    let broken = dir.join("broken.dae");
    std::fs::write(&broken, "<COLLADA><library_geometries>").unwrap();
    let o = wavepath(&["mitsuba", broken.to_str().unwrap(), out.to_str().unwrap()]);
    assert_refused(&o, "broken.dae");

    // The render's own limits on -s and -m (no sample_count 0, no
    // max_depth that overflows when Mitsuba's one more is added).
    for (flag, value) in [
        ("-s", "0"),
        ("-m", "4294967295"),
        ("-m", "1001"),
        // Mitsuba reads rr_depth as a signed 32-bit integer.
        ("--rr-depth", "2147483648"),
        ("--rr-depth", "0"),
    ] {
        let o = wavepath(&["mitsuba", flag, value, SCENE, out.to_str().unwrap()]);
        let err = text(&o.stderr);
        assert!(!o.status.success(), "{flag} {value} accepted");
        assert!(
            err.contains(value) && !err.contains("panicked"),
            "{flag} {value}: {err}"
        );
    }
    // A list flag given twice is refused, as the render refuses it, not
    // read as its first list.
    let o = wavepath(&[
        "mitsuba",
        "-r",
        "64",
        "48",
        "-r",
        "32",
        "32",
        SCENE,
        out.to_str().unwrap(),
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "-r twice: {err}");
    assert!(err.contains("--resolution"), "-r twice: {err}");
}

#[test]
fn converge_plots_extreme_values_without_hanging() {
    // A relMSE of 1e307 once sent the log axis code into an endless loop
    // (its padded range overflowed to infinity). Such points are left
    // out of the plot; the command ends, within a minute here.
    let dir = scratch("converge_extreme");
    let csv = dir.join("runs.csv");
    std::fs::write(
        &csv,
        "estimator,spp,seconds,rel_mse\nlight,1,0.01,1e-2\nlight,2,0.02,1e307\nlight,4,0.04,3e-3\n",
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .current_dir(&dir)
        .args(["converge", "--plot-csv", "runs.csv", "--plot", "runs.svg"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > std::time::Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("converge --plot-csv still running after a minute");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert!(status.success());
    let svg = std::fs::read_to_string(dir.join("runs.svg")).unwrap();
    assert!(svg.contains("<svg"));
}

/// `--diff-scale` must be a positive number (named in the refusal, before
/// any file is read); a good one is used and printed.
#[test]
fn compare_takes_a_positive_diff_scale_only() {
    let dir = scratch("compare_scale");
    let (a, b) = (dir.join("a.exr"), dir.join("b.exr"));
    render(&a, 16, 12, 2, 1);
    render(&b, 16, 12, 2, 2);
    let diff = dir.join("d.png");
    let compare = |scale: &str| {
        let paths = [&a, &b, &diff].map(|p| p.to_str().unwrap().to_string());
        wavepath(&[
            "compare",
            &paths[0],
            &paths[1],
            "--diff",
            &paths[2],
            "--diff-scale",
            scale,
        ])
    };
    for bad in ["0", "-1", "inf", "NaN"] {
        let o = compare(bad);
        let says = format!("--diff-scale must be a positive number, got {bad}");
        assert_usage_error(&o, "compare", &says);
        assert!(!diff.exists(), "{bad}");
    }
    // --diff names a PNG that can be written, found out before comparing.
    let paths = [&a, &b].map(|p| p.to_str().unwrap().to_string());
    for (diff, says) in [
        ("d.jpg", "--diff d.jpg: writes a PNG"),
        ("no/such/d.png", "--diff no/such/d.png: there is no folder"),
    ] {
        let o = wavepath(&["compare", &paths[0], &paths[1], "--diff", diff]);
        assert_usage_error(&o, "compare", says);
    }
    let o = compare("0.5");
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.contains("red >= 5.000e-1"), "{out}");
    assert!(diff.is_file());
}

/// What `compare` adds beyond the metrics depends on the files: a warning
/// naming a file with NaN or infinite pixels; the reference's own noise
/// when the reference carries standard errors; the same-mean test only
/// when both do.
#[test]
fn compare_says_what_the_files_allow_and_no_more() {
    use glam::Vec3;
    use wavepath::film::Image;
    use wavepath::film::output::{write_exr, write_exr_with_error};
    let dir = scratch("compare_extras");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let mut plain = Image::new(8, 4);
    plain.pixels.fill(Vec3::splat(0.5));
    let mut noisy = plain.clone();
    noisy.variance.fill(Vec3::splat(1e-4));
    noisy.samples.fill(16);
    write_exr(&plain, &dir.join("plain.exr"), false).unwrap();
    write_exr_with_error(&noisy, &dir.join("noisy.exr"), &[]).unwrap();
    // wavepath writes non-finite pixels as 0, so this file is written
    // directly: two bad pixels in 8×4.
    exr::prelude::write_rgb_file(dir.join("broken.exr"), 8, 4, |x, y| match (x, y) {
        (3, 0) => (f32::NAN, 0.5, 0.5),
        (1, 1) => (0.5, f32::INFINITY, 0.5),
        _ => (0.5, 0.5, 0.5),
    })
    .unwrap();
    let compare = |image: &str, reference: &str| {
        let o = wavepath(&[
            "compare",
            &s(&dir.join(format!("{image}.exr"))),
            &s(&dir.join(format!("{reference}.exr"))),
        ]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        (text(&o.stdout), text(&o.stderr))
    };
    let says = |out: &str| {
        (
            out.contains("reference noise"),
            out.contains("same-mean test"),
        )
    };

    let (out, err) = compare("plain", "plain");
    assert_eq!(says(&out), (false, false), "{out}");
    assert_eq!(err, "");
    let (out, _) = compare("plain", "noisy");
    assert_eq!(says(&out), (true, false), "{out}");
    let (out, _) = compare("noisy", "plain");
    assert_eq!(says(&out), (false, false), "{out}");
    let (out, _) = compare("noisy", "noisy");
    assert_eq!(says(&out), (true, true), "{out}");
    assert!(out.contains("consistent"), "{out}");

    // Few samples: the per-pixel test is warned about, naming the file;
    // --same-estimator needs both files' sample counts.
    let (_, err) = compare("noisy", "noisy");
    assert_eq!(
        err.matches("noisy.exr: some pixels hold only 16 samples")
            .count(),
        2,
        "{err}"
    );
    let mut uncounted = noisy.clone();
    uncounted.samples.fill(0);
    write_exr_with_error(&uncounted, &dir.join("uncounted.exr"), &[]).unwrap();
    let same = |image: &str| {
        let o = wavepath(&[
            "compare",
            "--same-estimator",
            &s(&dir.join(format!("{image}.exr"))),
            &s(&dir.join("noisy.exr")),
        ]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        text(&o.stderr)
    };
    assert_eq!(same("noisy"), "");
    // 32 samples a pixel are enough.
    let mut enough = noisy.clone();
    enough.samples.fill(32);
    write_exr_with_error(&enough, &dir.join("enough.exr"), &[]).unwrap();
    assert_eq!(compare("enough", "enough").1, "");
    let err = same("uncounted");
    assert!(
        err.contains("--same-estimator needs sample counts in both files, and ")
            && err.contains("uncounted.exr has none"),
        "{err}"
    );
    assert!(err.contains("noisy.exr: some pixels hold only 16"), "{err}");
    // Nor can it do anything without standard errors in both files.
    let err = same("plain");
    assert!(
        err.contains("--same-estimator: no same-mean test, as ")
            && err.contains("plain.exr has no standard-error channels"),
        "{err}"
    );

    let (_, err) = compare("broken", "plain");
    assert!(
        err.contains("broken.exr: 2 pixels are NaN or infinite"),
        "{err}"
    );
    assert!(!err.contains("plain.exr"), "{err}");
    let (_, err) = compare("plain", "broken");
    assert!(
        err.contains("broken.exr: 2 pixels are NaN or infinite"),
        "{err}"
    );
}

/// A report that cannot be written (a full disk: `/dev/full`) is an
/// error naming stdout, not a silent success; a reader that went away is
/// not (`compare_goes_quietly_when_its_reader_stops_reading`).
#[test]
fn compare_fails_when_its_report_cannot_be_written() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("skipped: no /dev/full on this system");
        return;
    };
    let dir = scratch("compare_full");
    let image = dir.join("a.exr");
    render(&image, 8, 6, 1, 0);
    let path = image.to_str().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .args(["compare", path, path])
        .stdout(full)
        .output()
        .unwrap();
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot write to stdout"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// The own relMSE a `converge --make-reference` run printed, `replicates`
/// being the number it must say it rendered.
fn own_rel_mse(out: &str, replicates: u32) -> f64 {
    let said = format!("its own relMSE, measured from {replicates} independent replicates: ");
    out.split(&said)
        .nth(1)
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no '{said}' in: {out}"))
}

/// Runs `wavepath converge` in `dir` with `args`; must succeed. Returns
/// stdout and stderr.
fn converge(dir: &Path, args: &[&str]) -> (String, String) {
    let o = wavepath_in(dir, &[&["converge"], args, &[SCENE]].concat());
    assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
    (text(&o.stdout), text(&o.stderr))
}

/// The CSV's rows as (estimator, spp, seconds, relMSE, relMSE less the
/// reference's noise, CPU seconds).
fn csv_rows(path: &Path) -> Vec<(String, u32, f64, f64, f64, f64)> {
    let csv = std::fs::read_to_string(path).unwrap();
    csv.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let n = |i: usize| f[i].parse::<f64>().unwrap();
            (f[0].to_string(), n(1) as u32, n(2), n(3), n(5), n(6))
        })
        .collect()
}

/// Flags of `converge` that break their rule are refused, naming the flag
/// and the value, before anything is rendered.
#[test]
fn converge_refuses_bad_budgets_and_targets() {
    let dir = scratch("converge_flags");
    render(&dir.join("ref.exr"), 8, 6, 4, 0);
    let base = ["-q", "-r", "8", "6", "--ref", "ref.exr"];
    let refused = |flags: &[&str], says: &str| {
        let o = wavepath_in(&dir, &[&["converge"], &base[..], flags, &[SCENE]].concat());
        assert_usage_error(&o, "converge", says);
        assert!(!dir.join("converge.csv").exists(), "{flags:?}");
    };
    // (flag, value given, value as the message shows it)
    for (flag, value, shown) in [
        ("--seconds", "0", "0"),
        ("--seconds", "inf", "inf"),
        ("--seconds", "-1", "-1"),
        ("--targets", "1e-2,0", "0"),
        ("--targets", "inf", "inf"),
        ("--targets", "-0.001", "-0.001"),
    ] {
        let rule = match flag {
            "--seconds" => "must be a positive number",
            _ => "must be positive numbers",
        };
        // As two arguments: a negative value is a value, not a flag.
        refused(&[flag, value], &format!("{flag} {rule}, got {shown}"));
    }
    refused(
        &["--make-reference", "--estimators", "hemisphere,light"],
        "--make-reference renders one estimator",
    );
    refused(
        &["--make-reference", "-s", "1"],
        "--make-reference -s 1: a reference takes at least 2 samples per pixel",
    );
    // Render flags that mean nothing here are refused, not ignored, and
    // outputs that cannot be written are found before anything renders.
    for (flags, says) in [
        (&["-f", "x.png"][..], "converge: -f is not used"),
        (&["-a", "8", "0.1"], "converge: -a is not used"),
        (&["-p", "0", "0", "4", "4"], "converge: -p is not used"),
        (&["--no-adaptive"], "converge: --no-adaptive is not needed"),
        (
            &["-s", "64"],
            "converge: -s sets the reference's samples per pixel",
        ),
        (&["--tonemap", "srgb"], "converge: --tonemap is not used"),
        (&["--stats"], "converge: --stats is not used"),
        (
            &["--shading", "normals"],
            "--shading normals: converge measures the light-transport estimators",
        ),
        (
            &["--csv", "no/such/folder/c.csv"],
            "--csv no/such/folder/c.csv: there is no folder no/such/folder",
        ),
        // The render's own flag checks, refused with converge's usage line.
        (
            &["-b", "-1"],
            "-b: lens radius must be a non-negative number, got -1",
        ),
        (
            &["--plot-csv", "c.csv"],
            "--plot-csv needs --plot <FILE.svg>",
        ),
    ] {
        refused(flags, says);
    }
    std::fs::create_dir(dir.join("taken.svg")).unwrap();
    refused(&["--plot", "taken.svg"], "--plot taken.svg: is a folder");
    let o = wavepath_in(
        &dir,
        &[
            "converge",
            "--make-reference",
            "-r",
            "8",
            "6",
            "--ref",
            "no/such/r.exr",
            SCENE,
        ],
    );
    assert_usage_error(&o, "converge", "--ref no/such/r.exr: there is no folder");

    // The help lists what converge uses, with the reference's default spp.
    let help = text(&wavepath(&["converge", "--help"]).stdout);
    assert!(help.contains("[default: 1024]"), "{help}");
    let options: Vec<&str> = help
        .lines()
        .map(str::trim_start)
        .filter(|l| l.starts_with('-'))
        .collect();
    for listed in ["-s, --spp", "-e, --envmap"] {
        assert!(options.iter().any(|l| l.starts_with(listed)), "{help}");
    }
    for hidden in [
        "-f, --output",
        "-a, --adaptive",
        "--no-adaptive",
        "-p, --region",
        "--tonemap",
        "--stats",
    ] {
        assert!(
            !options.iter().any(|l| l.starts_with(hidden)),
            "{hidden} listed: {help}"
        );
    }
}

/// Budgets double from 1 to `--max-spp` (256 by default); `--seconds`
/// stops the doubling after the first render that takes that long, and
/// without `--max-spp` time alone stops it, past 256.
#[test]
fn converge_doubles_budgets_until_told_to_stop() {
    let dir = scratch("converge_budgets");
    render(&dir.join("ref.exr"), 8, 6, 4, 0);
    let base = ["-q", "-m", "1", "-r", "8", "6", "--ref", "ref.exr"];
    let budgets = |extra: &[&str]| -> Vec<(u32, f64)> {
        converge(&dir, &[&base[..], extra].concat());
        csv_rows(&dir.join("converge.csv"))
            .iter()
            .map(|r| (r.1, r.2))
            .collect()
    };
    let spps = |rows: &[(u32, f64)]| rows.iter().map(|r| r.0).collect::<Vec<_>>();
    assert_eq!(spps(&budgets(&[])), [1, 2, 4, 8, 16, 32, 64, 128, 256]);
    assert_eq!(spps(&budgets(&["--max-spp", "4"])), [1, 2, 4]);
    // Every render takes more than a nanosecond: one budget.
    assert_eq!(
        spps(&budgets(&["--max-spp", "4", "--seconds", "1e-9"])),
        [1]
    );
    // 256 samples of 48 pixels take far less than 0.25 s: the doubling
    // goes on past the default cap and stops at the first render that
    // took 0.25 s.
    let rows = budgets(&["--seconds", "0.25"]);
    let (last, earlier) = rows.split_last().unwrap();
    assert!(last.0 > 256 && last.1 >= 0.25, "{rows:?}");
    assert!(earlier.iter().all(|r| r.1 < 0.25), "{rows:?}");
}

/// What converge says of its reference and errors: a reference without
/// standard-error channels is warned about and nothing is subtracted; one
/// made by `--make-reference` has its own relMSE printed, drawn in the
/// plot and subtracted in the CSV and in the "less the reference's noise"
/// times (from wall and from CPU time); each estimator's times come from
/// its own renders; CPU times are within what the threads could use.
#[test]
fn converge_reports_each_estimator_against_the_references_noise() {
    let dir = scratch("converge_noise");
    let base = ["-m", "2", "-r", "24", "18", "-t", "2"];
    // A noisy reference (4 spp, as many as the renders measured against
    // it), so that its own relMSE is about half the measured one; the line
    // before the render unless -q.
    let (out, err) = converge(
        &dir,
        &[
            &base[..],
            &[
                "--make-reference",
                "-s",
                "4",
                "--estimators",
                "light",
                "--ref",
                "ref.exr",
            ],
        ]
        .concat(),
    );
    assert!(err.contains("rendering the reference: "), "{err}");
    assert!(err.contains(", 4 spp (4 replicates of 1), -m 2,"), "{err}");
    let floor = own_rel_mse(&out, 4);
    assert!(floor > 0.0, "{out}");
    let (_, err) = converge(
        &dir,
        &[
            &base[..],
            &["-q", "--make-reference", "-s", "2", "--ref", "quiet.exr"],
        ]
        .concat(),
    );
    assert_eq!(err, "");

    let run = [
        "-q",
        "--ref",
        "ref.exr",
        "--estimators",
        "hemisphere,light",
        "--max-spp",
        "4",
    ];
    let (out, err) = converge(&dir, &[&base[..], &run[..]].concat());
    assert_eq!(err, "");
    assert!(out.contains("own relMSE about"), "{out}");
    let svg = std::fs::read_to_string(dir.join("converge.svg")).unwrap();
    assert!(svg.contains("reference noise"), "the floor is drawn");
    let rows = csv_rows(&dir.join("converge.csv"));
    for r in &rows {
        // Printed to four digits, and the floor to three.
        assert!(
            (r.4 - (r.3 - floor)).abs() <= 1e-3 * r.3 + 1e-3 * floor,
            "{r:?}"
        );
        // Two 10 ms ticks of slack on the CPU time of two threads.
        assert!(r.5 >= 0.0 && r.5 <= 2.0 * r.2 + 0.025, "{r:?}");
    }
    let best = |name: &str| {
        rows.iter()
            .filter(|r| r.0 == name)
            .map(|r| r.3)
            .fold(f64::INFINITY, f64::min)
    };
    let (light, hemisphere) = (best("light"), best("hemisphere"));
    // Between the two estimators' best errors: light sampling reaches it,
    // uniform hemisphere sampling does not.
    let between = (light * hemisphere).sqrt();
    assert!(
        hemisphere - floor > 1.5 * between && light < between / 1.5,
        "{rows:?}"
    );
    // Below light sampling's best measured error, above that error less
    // the reference's noise: reached only once the noise is subtracted.
    let below = light - 0.5 * floor;
    assert!(
        light - floor < 0.9 * below && below < 0.95 * light,
        "{rows:?}"
    );

    let targets = format!("{between:e},{below:e}");
    let (out, _) = converge(
        &dir,
        &[&base[..], &run[..], &["--targets", &targets]].concat(),
    );
    let lines: Vec<&str> = out
        .lines()
        .filter(|l| l.contains(": time to relMSE <="))
        .collect();
    let line = |estimator: &str, k: usize, cpu: bool| {
        lines
            .iter()
            .filter(|l| l.starts_with(&format!("{estimator}: ")) && l.contains("CPU time") == cpu)
            .nth(k)
            .copied()
            .expect(&out)
    };
    // (estimator, target, from CPU time, which figure, reached)
    let noise = "less the reference's noise";
    let mut want = vec![
        ("hemisphere", 0, false, "measured", false),
        ("light", 0, false, "measured", true),
        ("light", 1, false, "measured", false),
    ];
    for cpu in [false, true] {
        want.extend([
            ("hemisphere", 0, cpu, noise, false),
            ("light", 0, cpu, noise, true),
            ("light", 1, cpu, noise, true),
        ]);
    }
    for (estimator, k, cpu, figure, reached) in want {
        let l = line(estimator, k, cpu);
        let missed = l.contains(&format!("not reached ({figure})"));
        assert_eq!(!missed, reached, "{l}\n{out}");
    }

    // A reference without standard errors: warned about, no floor.
    render(&dir.join("plain.exr"), 24, 18, 16, 7);
    let (out, err) = converge(
        &dir,
        &[
            &base[..],
            &[
                "-q",
                "--ref",
                "plain.exr",
                "--max-spp",
                "2",
                "--plot",
                "plain.svg",
            ],
        ]
        .concat(),
    );
    assert!(
        err.contains("plain.exr has no standard-error channels"),
        "{err}"
    );
    assert!(!out.contains("own relMSE"), "{out}");
    let svg = std::fs::read_to_string(dir.join("plain.svg")).unwrap();
    assert!(!svg.contains("reference noise"));
    for r in csv_rows(&dir.join("converge.csv")) {
        assert_eq!(r.3, r.4, "{r:?}");
    }
}
