//! Bad scene input: every malformed file is a [`LoadError`] that names the
//! file, the element and its line, and the loader never panics; the CLI
//! turns it into a one-line `error:` and a non-zero exit, writing no image.
//!
//! Each case is a targeted edit of [`BASE`], a small valid scene, so a case
//! tests exactly one defect.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::process::Command;

use wavepath::scene::collada::{LoadError, load_file, load_str};

mod common;
use common::fixture::{BASE, NAME, POSITION_ACCESSOR, edit, edits, line_of};

/// Loads `text`, which must fail without panicking.
fn load_err(text: &str) -> LoadError {
    match catch_unwind(AssertUnwindSafe(|| load_str(text, Path::new(NAME)))) {
        Err(_) => panic!("the loader panicked"),
        Ok(Ok(_)) => panic!("a bad scene loaded without error"),
        Ok(Err(e)) => e,
    }
}

/// The error for `text`: it must name the file, `element`, and the line of
/// `marker` in `text`, and its message must contain `words`.
fn expect_at(text: &str, element: &str, marker: &str, words: &str) -> LoadError {
    let e = load_err(text);
    let line = line_of(text, marker);
    assert_eq!(e.path, Path::new(NAME), "{e}");
    assert_eq!(e.element.as_deref(), Some(element), "wrong element: {e}");
    assert_eq!(e.line, Some(line), "wrong line: {e}");
    assert!(e.message.contains(words), "{e}\n(message lacks {words:?})");
    let shown = e.to_string();
    assert!(
        shown.starts_with(&format!("{NAME}:{line}: <{element}>: ")),
        "{shown}"
    );
    assert!(!shown.contains('\n'), "multi-line error: {shown:?}");
    e
}

/// [`BASE`] with `from` → `to` fails at `element` on the line of `to`.
fn case(from: &str, to: &str, element: &str, words: &str) -> LoadError {
    expect_at(&edit(from, to), element, to, words)
}

/// A scratch directory for files the tests write.
fn scratch() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_input");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `bytes` to a scratch file called `name`.
fn scratch_file(name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let path = scratch().join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Runs the CLI on `scene`: it must exit 1 with a single `error:` line
/// containing `words`, no panic, and no image written.
fn cli_rejects(scene: &Path, words: &str) {
    let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
    let image = scratch().join(format!("{stem}-cli-out.png"));
    let _ = std::fs::remove_file(&image);
    let out = Command::new(env!("CARGO_BIN_EXE_wavepath"))
        .args(["-t", "1", "-s", "1", "-r", "8", "8", "-f"])
        .arg(&image)
        .arg(scene)
        .output()
        .expect("cannot run the wavepath binary");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "the CLI panicked:\n{stderr}");
    assert_eq!(out.status.code(), Some(1), "exit status; stderr:\n{stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "expected one line on stderr:\n{stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(lines[0].contains(words), "{stderr}\n(lacks {words:?})");
    assert!(
        !image.exists(),
        "an image was written for a bad scene: {}",
        image.display()
    );
}

// ---------------------------------------------------------------- the base

#[test]
fn base_scene_loads() {
    let scene = load_str(BASE, Path::new(NAME)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.geometry.triangles.len(), 1);
    assert_eq!(scene.geometry.spheres.len(), 1);
    assert_eq!(scene.lights.len(), 1);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // The <triangles> form used by one case below is valid when counted right.
    let tris = edits(&[
        (
            r#"<polylist material="grey-sym" count="1">"#,
            r#"<triangles material="grey-sym" count="1">"#,
        ),
        ("<vcount>3</vcount>\n", ""),
        ("</polylist>", "</triangles>"),
    ]);
    let scene = load_str(&tris, Path::new(NAME)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.geometry.triangles.len(), 1);
}

// ------------------------------------------------------------ malformed XML

#[test]
fn unclosed_tag() {
    let text = edit("<zfar>100</zfar>", "<zfar>100");
    let e = load_err(&text);
    // The parser notices at the enclosing close tag.
    assert_eq!(e.path, Path::new(NAME));
    assert_eq!(e.line, Some(line_of(&text, "</perspective>")), "{e}");
    assert_eq!(e.element.as_deref(), Some("zfar"), "{e}");
    assert!(e.message.contains("not well-formed XML"), "{e}");
    assert!(e.message.contains("zfar"), "{e}");
}

#[test]
fn empty_tag_missing_its_bracket_via_cli() {
    // The parser names the newline it found instead of '>': still one line.
    let text = edit(
        r##"<instance_camera url="#cam"/>"##,
        r##"<instance_camera url="#cam"/"##,
    );
    let line = line_of(&text, "<instance_camera");
    let e = load_err(&text);
    assert_eq!(e.line, Some(line), "{e}");
    assert!(!e.to_string().contains('\n'), "multi-line error: {e:?}");
    assert!(e.message.contains(r"expected '>' not '\n'"), "{e}");
    let path = scratch_file("no_bracket.dae", &text);
    cli_rejects(
        &path,
        &format!("no_bracket.dae:{line}: not well-formed XML"),
    );
}

#[test]
fn bad_entity() {
    let text = edit(
        "<color>0.5 0.5 0.5 1</color>",
        "<color>0.5 &bogus; 0.5 1</color>",
    );
    let e = load_err(&text);
    assert_eq!(e.path, Path::new(NAME));
    assert_eq!(e.line, Some(line_of(&text, "&bogus;")), "{e}");
    assert!(e.message.contains("not well-formed XML"), "{e}");
    assert!(e.message.contains("bogus"), "{e}");
    assert!(e.to_string().starts_with(&format!("{NAME}:")));
}

#[test]
fn mismatched_close_tag_via_cli() {
    let text = edit("</light>", "</lamp>");
    let path = scratch_file("mismatched.dae", &text);
    let e = load_file(&path).unwrap_err();
    assert_eq!(e.path, path);
    assert_eq!(e.line, Some(line_of(&text, "</lamp>")), "{e}");
    assert_eq!(e.element.as_deref(), Some("light"), "{e}");
    cli_rejects(
        &path,
        &format!("mismatched.dae:{}:", line_of(&text, "</lamp>")),
    );
}

#[test]
fn truncated_dragon() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/scenes/malformed/dragon_truncated.dae");
    if !path.is_file() {
        eprintln!("skipping: {} is absent", path.display());
        return;
    }
    let e = catch_unwind(|| load_file(&path))
        .expect("the loader panicked")
        .expect_err("a truncated file loaded");
    assert_eq!(e.path, path);
    let text = std::fs::read_to_string(&path).unwrap();
    let last_line = text.lines().count() as u32;
    assert_eq!(e.line, Some(last_line), "{e}");
    assert!(e.message.contains("not well-formed XML"), "{e}");
    assert!(e.message.contains("truncated"), "{e}");
    // The innermost element left open is named.
    assert_eq!(e.element.as_deref(), Some("float_array"), "{e}");
    cli_rejects(&path, &format!("dragon_truncated.dae:{last_line}:"));
}

#[test]
fn truncated_files_name_the_element_they_end_inside() {
    // BASE cut off just after `cut` (and blank lines added, as an editor
    // might): the error is on the last line that holds text and names the
    // innermost element left open, with the line it was opened on.
    for (cut, element, opened) in [
        (
            r#"count="9">0 0 0 1"#,
            "float_array",
            r#"<float_array id="tri-pos-array""#,
        ),
        (
            r#"<float_array id="tri-pos-ar"#,
            "source",
            r#"<source id="tri-pos">"#,
        ),
        (
            r##"<instance_effect url="#fx"/>"##,
            "material",
            r#"<material id="mat""#,
        ),
        (
            "<zfar>100</zfar>\n          </perspective>",
            "technique_common",
            "<technique_common>\n          <perspective>",
        ),
    ] {
        let at = BASE.find(cut).unwrap() + cut.len();
        let text = format!("{}\n\n  \n", &BASE[..at]);
        let e = load_err(&text);
        let last_line = BASE[..at].lines().count() as u32;
        assert_eq!(e.path, Path::new(NAME), "{e}");
        assert_eq!(e.line, Some(last_line), "{cut:?}: {e}");
        assert_eq!(e.element.as_deref(), Some(element), "{cut:?}: {e}");
        let want = format!(
            "the file ends inside <{element}> (opened on line {}); is it truncated?",
            line_of(BASE, opened)
        );
        assert!(e.message.contains(&want), "{cut:?}: {e}\n(lacks {want:?})");
    }
    // Cut inside a comment, CDATA section, processing instruction or
    // entity: the parser's own complaint, then the same hint.
    let cut = r##"<instance_effect url="#fx"/>"##;
    let at = BASE.find(cut).unwrap() + cut.len();
    for (tail, parser_says) in [
        ("<!-- a note", "expected '-->'"),
        ("<![CDATA[ 1 2", "expected ']]>'"),
        ("<?editor x", "expected '?>'"),
        ("&am", "entity"),
    ] {
        let text = format!("{}\n{tail}", &BASE[..at]);
        let e = load_err(&text);
        let last_line = text.lines().count() as u32;
        assert_eq!(e.line, Some(last_line), "{tail:?}: {e}");
        assert_eq!(e.element.as_deref(), Some("material"), "{tail:?}: {e}");
        assert!(e.message.contains(parser_says), "{tail:?}: {e}");
        assert!(
            e.message.ends_with(&format!(
                "the file ends inside <material> (opened on line {}); is it truncated?",
                line_of(BASE, r#"<material id="mat""#)
            )),
            "{tail:?}: {e}"
        );
    }
    // The same faults with the file going on, and a whole file with
    // something after its root element, are not called truncation.
    let mut whole = Vec::new();
    for tail in ["<!-- a note", "&am"] {
        whole.push(format!("{}\n{tail}\n{}", &BASE[..at], &BASE[at..]));
    }
    for tail in ["junk", "\0\0", "\u{1a}", "<!-- a note", "&amp;"] {
        whole.push(format!("{BASE}{tail}"));
    }
    for text in whole {
        let e = load_err(&text);
        assert!(!e.message.contains("truncated"), "{e}");
    }
    // Cut inside the root's own start tag: nothing was opened yet.
    let cut = "COLLADASchema";
    let text = &BASE[..BASE.find(cut).unwrap() + cut.len()];
    let e = load_err(text);
    assert_eq!(e.line, Some(2), "{e}");
    assert!(
        e.message.contains("ends before the root element is closed"),
        "{e}"
    );
}

// ------------------------------------------------ counts vs. array lengths

#[test]
fn float_array_count_disagrees() {
    case(
        r#"count="9">0 0 0 1 0 0 0 1 0"#,
        r#"count="10">0 0 0 1 0 0 0 1 0"#,
        "float_array",
        "count=\"10\" but the array holds 9 numbers",
    );
}

#[test]
fn accessor_count_too_large() {
    case(
        r##"<accessor source="#tri-pos-array" count="3" stride="3">"##,
        r##"<accessor source="#tri-pos-array" count="4" stride="3">"##,
        "accessor",
        "reach past the 9 numbers",
    );
}

#[test]
fn accessor_stride_too_large() {
    case(
        r##"<accessor source="#tri-pos-array" count="3" stride="3">"##,
        r##"<accessor source="#tri-pos-array" count="3" stride="4">"##,
        "accessor",
        "reach past the 9 numbers",
    );
}

#[test]
fn accessor_stride_too_small() {
    case(
        r##"<accessor source="#tri-pos-array" count="3" stride="3">"##,
        r##"<accessor source="#tri-pos-array" count="3" stride="2">"##,
        "accessor",
        "at least 3 components",
    );
}

#[test]
fn source_without_accessor_not_whole_tuples() {
    // Without an accessor the numbers are packed x y z tuples: ten are not.
    let text = edits(&[
        (POSITION_ACCESSOR, ""),
        (
            r#"count="9">0 0 0 1 0 0 0 1 0<"#,
            r#"count="10">0 0 0 1 0 0 0 1 0 7<"#,
        ),
    ]);
    expect_at(
        &text,
        "float_array",
        r#"count="10""#,
        "10 numbers is not a whole number of 3-tuples",
    );
}

/// [`BASE`] with its `<polylist>` turned into a `<kind>` list with the
/// attribute `count` and the index lists `p` (no `<vcount>`).
fn with_list(kind: &str, count: &str, p: &str) -> String {
    edits(&[
        (
            r#"<polylist material="grey-sym" count="1">"#,
            &format!(r#"<{kind} material="grey-sym" {count}>"#),
        ),
        ("<vcount>3</vcount>\n", ""),
        ("<p>0 0 0 1 0 1 2 0 2</p>", p),
        ("</polylist>", &format!("</{kind}>")),
    ])
}

#[test]
fn polygons_and_triangles_lists_checked_against_their_counts() {
    // <polygons>: one <p> per polygon, each a whole number of corners (3
    // inputs each), as many as count says.
    let polygons = |count: &str, p: &str| with_list("polygons", count, p);
    let ok = polygons(r#"count="1""#, "<p>0 0 0 1 0 1 2 0 2</p>");
    assert_eq!(
        load_str(&ok, Path::new(NAME))
            .unwrap()
            .geometry
            .triangles
            .len(),
        1
    );
    expect_at(
        &polygons(r#"count="2""#, "<p>0 0 0 1 0 1 2 0 2</p>"),
        "polygons",
        r#"count="2""#,
        "count=\"2\" but 1 polygons are listed",
    );
    expect_at(
        &polygons(r#"count="1""#, "<p>0 0 0 1 0 1 2 0</p>"),
        "p",
        "<p>0 0 0 1 0 1 2 0</p>",
        "8 indices is not a whole number of 3-index corners",
    );
    // <triangles> with triangles to list but no <p>.
    let text = with_list("triangles", r#"count="1""#, "");
    expect_at(&text, "triangles", "<triangles ", "missing <p>");
}

#[test]
fn accessor_naming_nothing_or_another_array() {
    case(
        r##"<accessor source="#tri-pos-array" count="3" stride="3">"##,
        r##"<accessor source="#zzz" count="3" stride="3">"##,
        "accessor",
        r##"source="#zzz" refers to no element"##,
    );
    case(
        r##"<accessor source="#tri-pos-array" count="3" stride="3">"##,
        r##"<accessor source="#tri-uv-array" count="3" stride="3">"##,
        "accessor",
        "names another <source>'s array",
    );
}

#[test]
fn accessor_count_not_a_number() {
    case(
        r##"<accessor source="#tri-uv-array" count="3" stride="2"/>"##,
        r##"<accessor source="#tri-uv-array" count="-3" stride="2"/>"##,
        "accessor",
        "not a non-negative integer",
    );
}

#[test]
fn polylist_count_disagrees_with_vcount() {
    case(
        r#"<polylist material="grey-sym" count="1">"#,
        r#"<polylist material="grey-sym" count="2">"#,
        "polylist",
        "<vcount> lists 1 polygons",
    );
}

#[test]
fn vcount_sum_disagrees_with_p() {
    let text = edit("<vcount>3</vcount>", "<vcount>4</vcount>");
    expect_at(&text, "p", "<p>", "but <p> holds 9");
}

#[test]
fn triangles_count_disagrees_with_p() {
    let text = edits(&[
        (
            r#"<polylist material="grey-sym" count="1">"#,
            r#"<triangles material="grey-sym" count="2">"#,
        ),
        ("<vcount>3</vcount>\n", ""),
        ("</polylist>", "</triangles>"),
    ]);
    expect_at(&text, "p", "<p>", "but <p> holds 9");
}

#[test]
fn huge_input_offset() {
    // usize::MAX: the index stride (largest offset + 1) must not overflow.
    case(
        r#"offset="2" set="0""#,
        r#"offset="18446744073709551615" set="0""#,
        "input",
        "too large",
    );
}

// --------------------------------------------------- indices out of range

#[test]
fn position_index_out_of_range() {
    case(
        "<p>0 0 0 1 0 1 2 0 2</p>",
        "<p>0 0 0 1 0 1 3 0 2</p>",
        "p",
        "vertex index 3 is out of range (3 positions)",
    );
}

#[test]
fn normal_index_out_of_range() {
    case(
        "<p>0 0 0 1 0 1 2 0 2</p>",
        "<p>0 0 0 1 0 1 2 1 2</p>",
        "p",
        "NORMAL index 1 is out of range (1 entries)",
    );
}

#[test]
fn texcoord_index_out_of_range() {
    case(
        "<p>0 0 0 1 0 1 2 0 2</p>",
        "<p>0 0 0 1 0 1 2 0 3</p>",
        "p",
        "TEXCOORD index 3 is out of range (3 entries)",
    );
}

#[test]
fn negative_index() {
    case(
        "<p>0 0 0 1 0 1 2 0 2</p>",
        "<p>0 0 0 1 0 1 -2 0 2</p>",
        "p",
        "value 7 is not a non-negative integer",
    );
}

// ------------------------------------------------ NaN, Inf, not a number

#[test]
fn bad_numbers_in_float_array() {
    for (bad, words) in [
        ("nan", "not finite"),
        ("NaN", "not finite"),
        ("inf", "not finite"),
        ("-infinity", "not finite"),
        ("1e39", "not finite"),
        ("one", "not a number"),
        ("1,5", "not a number"),
    ] {
        let to = format!(r#"count="9">0 0 0 1 0 0 0 {bad} 0"#);
        let e = case(r#"count="9">0 0 0 1 0 0 0 1 0"#, &to, "float_array", words);
        assert!(e.message.contains("value 8"), "{e}");
    }
}

#[test]
fn bad_numbers_in_matrix() {
    for (bad, words) in [
        ("nan", "not finite"),
        ("inf", "not finite"),
        ("x", "not a number"),
    ] {
        case(
            "<matrix>1 0 0 0 0 1 0 0 0 0 1 5 0 0 0 1</matrix>",
            &format!("<matrix>1 0 0 0 0 1 0 0 0 0 1 {bad} 0 0 0 1</matrix>"),
            "matrix",
            words,
        );
    }
    case(
        "<matrix>1 0 0 0 0 1 0 0 0 0 1 5 0 0 0 1</matrix>",
        "<matrix>1 0 0 0 0 1 0 0 0 0 1 5 0 0 0</matrix>",
        "matrix",
        "expected 16 numbers, found 15",
    );
}

#[test]
fn bad_numbers_in_light_colour() {
    for (bad, words) in [
        ("nan", "not finite"),
        ("inf", "not finite"),
        ("bright", "not a number"),
    ] {
        case(
            "<color>1 1 1</color>",
            &format!("<color>1 {bad} 1</color>"),
            "color",
            words,
        );
    }
    case(
        "<color>1 1 1</color>",
        "<color>1 1</color>",
        "color",
        "expected 3 numbers, found 2",
    );
    let text = edit("<color>1 1 1</color>", "<color>1 -1 1</color>");
    expect_at(&text, "point", "<point>", "negative component");
}

#[test]
fn bad_numbers_in_sphere_radius() {
    for (bad, words) in [
        ("nan", "not finite"),
        ("inf", "not finite"),
        ("big", "not a number"),
        ("", "expected 1 numbers, found 0"),
    ] {
        case(
            "<radius>0.5</radius>",
            &format!("<radius>{bad}</radius>"),
            "radius",
            words,
        );
    }
}

#[test]
fn bad_number_via_cli() {
    let text = edit(
        r#"count="9">0 0 0 1 0 0 0 1 0"#,
        r#"count="9">0 0 0 1 0 nan 0 1 0"#,
    );
    let path = scratch_file("nan_position.dae", &text);
    let line = line_of(&text, "nan");
    cli_rejects(
        &path,
        &format!("nan_position.dae:{line}: <float_array>: value 6 is not finite"),
    );
}

// ---------------------------------------------------------- dangling urls

#[test]
fn dangling_instance_geometry() {
    case(
        r##"<instance_geometry url="#tri">"##,
        r##"<instance_geometry url="#nothing">"##,
        "instance_geometry",
        "url=\"#nothing\" refers to no element",
    );
}

#[test]
fn dangling_instance_material_target() {
    case(
        r##"symbol="grey-sym" target="#mat""##,
        r##"symbol="grey-sym" target="#nothing""##,
        "instance_material",
        "target=\"#nothing\" refers to no element",
    );
}

#[test]
fn dangling_instance_effect() {
    case(
        r##"<instance_effect url="#fx"/>"##,
        r##"<instance_effect url="#nothing"/>"##,
        "instance_effect",
        "url=\"#nothing\" refers to no element",
    );
}

#[test]
fn dangling_instance_light() {
    case(
        r##"<instance_light url="#lamp"/>"##,
        r##"<instance_light url="#nothing"/>"##,
        "instance_light",
        "url=\"#nothing\" refers to no element",
    );
}

#[test]
fn dangling_instance_camera() {
    case(
        r##"<instance_camera url="#cam"/>"##,
        r##"<instance_camera url="#nothing"/>"##,
        "instance_camera",
        "url=\"#nothing\" refers to no element",
    );
}

#[test]
fn dangling_vertex_source() {
    case(
        r##"source="#tri-vtx""##,
        r##"source="#nothing""##,
        "input",
        "source=\"#nothing\" refers to no element",
    );
}

#[test]
fn dangling_position_source() {
    case(
        r##"source="#tri-pos""##,
        r##"source="#nothing""##,
        "input",
        "source=\"#nothing\" refers to no element",
    );
}

#[test]
fn url_to_the_wrong_kind_of_element() {
    case(
        r##"<instance_geometry url="#tri">"##,
        r##"<instance_geometry url="#mat">"##,
        "instance_geometry",
        "refers to a <material>, expected a <geometry>",
    );
}

#[test]
fn url_that_is_not_local() {
    case(
        r##"<instance_light url="#lamp"/>"##,
        r##"<instance_light url="lights.dae#lamp"/>"##,
        "instance_light",
        "not a local reference",
    );
}

#[test]
fn dangling_url_via_cli() {
    let text = edit(
        r##"<instance_geometry url="#tri">"##,
        r##"<instance_geometry url="#nothing">"##,
    );
    let path = scratch_file("dangling.dae", &text);
    let line = line_of(&text, "#nothing");
    cli_rejects(
        &path,
        &format!("dangling.dae:{line}: <instance_geometry>: url=\"#nothing\" refers to no element"),
    );
}

// ------------------------------------------------ not a scene file at all

#[test]
fn missing_file() {
    let path = scratch().join("does-not-exist.dae");
    let _ = std::fs::remove_file(&path);
    let e = load_file(&path).unwrap_err();
    assert_eq!(e.path, path);
    assert_eq!((e.line, e.element.as_deref()), (None, None), "{e}");
    assert!(e.message.contains("cannot read"), "{e}");
    assert!(e.to_string().starts_with(&path.display().to_string()));
    cli_rejects(&path, "does-not-exist.dae: cannot read");
}

#[test]
fn directory() {
    let path = scratch().join("a-directory.dae");
    std::fs::create_dir_all(&path).unwrap();
    let e = load_file(&path).unwrap_err();
    assert_eq!(e.path, path);
    assert_eq!((e.line, e.element.as_deref()), (None, None), "{e}");
    assert!(e.message.contains("is a directory"), "{e}");
    cli_rejects(&path, "a-directory.dae: is a directory");
}

#[test]
fn empty_and_blank_files() {
    for (name, text) in [("empty.dae", ""), ("blank.dae", " \n\t\r\n  \n")] {
        let e = load_err(text);
        assert_eq!(e.path, Path::new(NAME));
        assert_eq!((e.line, e.element.as_deref()), (None, None), "{e}");
        assert!(e.message.contains("empty"), "{e}");
        let path = scratch_file(name, text);
        let e = load_file(&path).unwrap_err();
        assert_eq!(e.path, path);
        assert!(e.message.contains("empty"), "{e}");
    }
    cli_rejects(
        &scratch_file("empty-cli.dae", ""),
        "empty-cli.dae: file is empty",
    );
}

#[test]
fn non_utf8_bytes() {
    let at = BASE.find(r#"name="grey""#).unwrap() + r#"name="gr"#.len();
    let mut bytes = BASE.as_bytes().to_vec();
    bytes.insert(at, 0xff);
    let path = scratch_file("latin1.dae", &bytes);
    let e = load_file(&path).unwrap_err();
    assert_eq!(e.path, path);
    assert!(e.message.contains("not UTF-8"), "{e}");
    assert!(e.message.contains(&format!("offset {at}")), "{e}");
    assert_eq!(e.line, Some(line_of(BASE, r#"name="grey""#)), "{e}");
    cli_rejects(&path, "not UTF-8");
}

#[test]
fn svg_is_not_collada() {
    let text = "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\">\n  <rect width=\"1\" height=\"1\"/>\n</svg>\n";
    expect_at(text, "svg", "<svg", "not a COLLADA document");
}

#[test]
fn unknown_up_axis() {
    case(
        "<up_axis>Y_UP</up_axis>",
        "<up_axis>W_UP</up_axis>",
        "up_axis",
        "unknown up axis \"W_UP\"",
    );
}

// ---------------------------------------------------- values out of range

#[test]
fn non_positive_sphere_radius() {
    for r in ["0", "-0", "-1", "-1e-30"] {
        case(
            "<radius>0.5</radius>",
            &format!("<radius>{r}</radius>"),
            "radius",
            "must be positive",
        );
    }
}

#[test]
fn sphere_scaled_to_nothing() {
    let text = edit("<translate>2 0 0</translate>", "<scale>0 0 0</scale>");
    expect_at(
        &text,
        "instance_geometry",
        r##"<instance_geometry url="#ball">"##,
        "not a positive finite number",
    );
}

#[test]
fn sphere_reaching_beyond_single_precision() {
    // Finite centre and radius whose sum overflows: refused, as a mesh
    // vertex that overflows is.
    let text = edits(&[
        ("<radius>0.5</radius>", "<radius>2e38</radius>"),
        (
            "<translate>2 0 0</translate>",
            "<translate>-2e38 0 0</translate>",
        ),
    ]);
    expect_at(
        &text,
        "instance_geometry",
        r##"<instance_geometry url="#ball">"##,
        "reaches beyond single precision",
    );
}

#[test]
fn degenerate_area_light() {
    let text = edits(&[
        ("<point>", "<area>"),
        ("</point>", "</area>"),
        (
            "<translate>0 3 0</translate>",
            "<matrix>0 0 0 0 0 0 0 0 0 0 0 3 0 0 0 1</matrix>",
        ),
    ]);
    // The light itself is fine: its node's transform squashes it.
    expect_at(
        &text,
        "instance_light",
        r##"<instance_light url="#lamp"/>"##,
        "area light is degenerate",
    );
    // With an ordinary transform, the same area light loads.
    let ok = edits(&[("<point>", "<area>"), ("</point>", "</area>")]);
    load_str(&ok, Path::new(NAME)).unwrap_or_else(|e| panic!("{e}"));
    // Scaled until its area overflows, it is too large, not degenerate.
    let huge = edits(&[
        ("<point>", "<area>"),
        ("</point>", "</area>"),
        (
            "<translate>0 3 0</translate>",
            "<translate>0 3 0</translate><scale>3e19 3e19 1</scale>",
        ),
    ]);
    expect_at(
        &huge,
        "instance_light",
        r##"<instance_light url="#lamp"/>"##,
        "area light is too large under its node's transform: sides of 3e19 and 3e19",
    );
}

#[test]
fn zero_rotation_axis() {
    case(
        "<rotate>0 1 0 30</rotate>",
        "<rotate>0 0 0 30</rotate>",
        "rotate",
        "rotation axis is zero",
    );
}

#[test]
fn degenerate_lookat() {
    // The eye on the point of interest, and an up vector along the view.
    for lookat in [
        "<lookat>1 2 3  1 2 3  0 1 0</lookat>",
        "<lookat>0 0 0  0 5 0  0 -2 0</lookat>",
    ] {
        case(
            "<rotate>0 1 0 30</rotate>",
            lookat,
            "lookat",
            "degenerate lookat",
        );
    }
}

#[test]
fn transform_overflows_the_mesh() {
    let text = edits(&[
        ("<rotate>0 1 0 30</rotate>", "<scale>1e30 1e30 1e30</scale>"),
        (
            r#"count="9">0 0 0 1 0 0 0 1 0"#,
            r#"count="9">0 0 0 1e30 0 0 0 1e30 0"#,
        ),
    ]);
    expect_at(
        &text,
        "instance_geometry",
        r##"<instance_geometry url="#tri">"##,
        "not finite",
    );
}

/// Transforms finite node by node whose product overflows (a scale of
/// 1e20 around a translation of 1e20), and points of a light or camera that
/// overflow under a finite transform (a unit step added to a coordinate
/// near f32's limit): refused, not a light or camera at infinity.
#[test]
fn composed_transforms_that_overflow() {
    let text = edits(&[
        (
            "<node id=\"lamp-node\">\n        <translate>0 3 0</translate>",
            "<node id=\"outer\"><scale>1e20 1e20 1e20</scale><node id=\"lamp-node\">\n        <translate>0 1e20 0</translate>",
        ),
        (
            "<instance_light url=\"#lamp\"/>\n      </node>",
            "<instance_light url=\"#lamp\"/>\n      </node></node>",
        ),
    ]);
    expect_at(
        &text,
        "node",
        "<node id=\"lamp-node\">",
        "composed with its parents', overflows",
    );
    // z axis −3e38 and z translation 3e38: T·(0,0,−1,1) is 6e38.
    let reaching = "<matrix>1 0 0 0 0 1 0 0 0 0 -3e38 3e38 0 0 0 1</matrix>";
    let text = edits(&[
        ("<translate>0 3 0</translate>", reaching),
        ("<point>", "<directional>"),
        ("</point>", "</directional>"),
    ]);
    expect_at(
        &text,
        "instance_light",
        "<instance_light url=",
        "the light's placement overflows",
    );
    expect_at(
        &edit("<matrix>1 0 0 0 0 1 0 0 0 0 1 5 0 0 0 1</matrix>", reaching),
        "instance_camera",
        "<instance_camera url=",
        "view direction overflows",
    );
}

#[test]
fn invalid_field_of_view() {
    for fov in ["0", "-10", "180", "360"] {
        case(
            "<xfov>45</xfov>",
            &format!("<xfov>{fov}</xfov>"),
            "xfov",
            "outside (0°, 180°)",
        );
    }
    case("<xfov>45</xfov>", "<xfov>nan</xfov>", "xfov", "not finite");
    case(
        "<aspect_ratio>1.5</aspect_ratio>",
        "<aspect_ratio>0</aspect_ratio>",
        "aspect_ratio",
        "must be positive",
    );
}

#[test]
fn instance_node_cycle() {
    // A node that instances itself (twice: without cycle detection the walk
    // would branch 2^256 times before the depth limit).
    case(
        r#"<node id="lamp-node">"#,
        r##"<node id="lamp-node"><instance_node url="#lamp-node"/><instance_node url="#lamp-node"/>"##,
        "node",
        "cycle",
    );
}

/// [`BASE`] with a chain of nodes n0 … n_links hung under the lamp's
/// node (depth 0), so n_i is at depth i + 1: each instances the next once,
/// the last `doubling` links twice, and n_links holds `end`.
fn with_chain(links: usize, doubling: usize, end: &str) -> String {
    let mut chain = String::new();
    for i in 0..links {
        let next = format!(r##"<instance_node url="#n{}"/>"##, i + 1);
        let copies = if i + doubling >= links { 2 } else { 1 };
        chain.push_str(&format!(
            r#"<node id="n{i}">{}</node>"#,
            next.repeat(copies)
        ));
    }
    chain.push_str(&format!(r#"<node id="n{links}">{end}</node>"#));
    edits(&[
        (
            "<library_visual_scenes>",
            &format!("<library_nodes>{chain}</library_nodes><library_visual_scenes>"),
        ),
        (
            r#"<node id="lamp-node">"#,
            r##"<node id="lamp-node"><instance_node url="#n0"/>"##,
        ),
    ])
}

/// A chain of `levels` links, each instancing the next twice, down to a
/// node holding `leaf`: 2^levels instances of `leaf`.
fn with_doubling_chain(levels: usize, leaf: &str) -> String {
    with_chain(levels, levels, leaf)
}

#[test]
fn instance_node_exponential_expansion() {
    // No cycle, but each of 40 nodes instances the next twice: 2^40 instances.
    let text = with_doubling_chain(40, "");
    let e = load_err(&text);
    assert_eq!(e.element.as_deref(), Some("node"), "{e}");
    assert!(e.message.contains("node instances"), "{e}");
}

#[test]
fn nesting_and_instancing_limits_hold_at_their_stated_values() {
    // The triangle's node inside `levels` plain nodes: at depth 256 (the
    // stated limit) the scene loads, triangle and all.
    let nested = |levels: usize| {
        edits(&[
            (
                r#"<node id="tri-node">"#,
                &format!(r#"{}<node id="tri-node">"#, "<node>".repeat(levels)),
            ),
            (
                r#"      <node id="ball-node">"#,
                &format!(r#"{}<node id="ball-node">"#, "</node>".repeat(levels)),
            ),
        ])
    };
    let scene = load_str(&nested(256), Path::new(NAME)).unwrap();
    assert_eq!(scene.geometry.triangles.len(), 1);
    // Depth through <instance_node> counts alike: a chain of nodes, each
    // instancing the next once, the last (at depth `levels`) holding a
    // triangle.
    let triangle = r##"<instance_geometry url="#tri"/>"##;
    let chain = |levels: usize| with_chain(levels - 1, 0, triangle);
    let scene = load_str(&chain(256), Path::new(NAME)).unwrap();
    assert_eq!(scene.geometry.triangles.len(), 2);
    // One level more is refused at the node too deep, either way; far
    // deeper nesting the same way, without the recursive walks (the
    // primitive count first) running out of stack.
    for levels in [257, 100_000] {
        for text in [nested(levels), chain(levels)] {
            let e = load_err(&text);
            assert_eq!(e.element.as_deref(), Some("node"), "{e}");
            assert!(e.message.contains("nest deeper than 256 levels"), "{e}");
        }
    }
    // The primitive count, taken before the walk, reaches that deepest
    // level too: 20 doubling links make 2^20 instances of the end node
    // (depth 256), whose 65 triangles add up to more than 2^26 (with the
    // fixture's triangle, sphere and light, which counts two: 2^20 · 65 +
    // 4). Were the end not counted, the walk would stop at the node-visit
    // limit instead.
    let e = load_err(&with_chain(255, 20, &triangle.repeat(65)));
    assert_eq!(e.element.as_deref(), Some("visual_scene"), "{e}");
    assert!(e.message.contains("add up to 68157444 primitives"), "{e}");

    // Node instances: the four nodes of the scene, a hub instancing `mid`
    // 1023 times and `leaf` `direct` times, and `mid` instancing `leaf`
    // 1023 times: 4 + 1 + 1023 + 1023² + direct = 2^20 + direct − 1019.
    let fanned = |direct: usize| {
        let leaf = r##"<instance_node url="#leaf"/>"##;
        let mid = r##"<instance_node url="#mid"/>"##;
        edits(&[
            (
                "<library_visual_scenes>",
                &format!(
                    r#"<library_nodes><node id="mid">{}</node><node id="leaf"/></library_nodes><library_visual_scenes>"#,
                    leaf.repeat(1023)
                ),
            ),
            (
                r#"      <node id="ball-node">"#,
                &format!(
                    r#"<node id="hub">{}{}</node><node id="ball-node">"#,
                    mid.repeat(1023),
                    leaf.repeat(direct)
                ),
            ),
        ])
    };
    let scene = load_str(&fanned(1019), Path::new(NAME)).unwrap();
    assert_eq!(scene.geometry.triangles.len(), 1);
    let e = load_err(&fanned(1020));
    assert_eq!(e.element.as_deref(), Some("node"), "{e}");
    assert!(
        e.message.contains("more than 1048576 node instances"),
        "{e}"
    );
}

/// An unusable material record is not fatal: grey diffuse plus a warning,
/// as the reference does; a negative emission is an error.
#[test]
fn unusable_material_records_fall_back_to_grey_with_a_warning() {
    for record in [
        "<velvet><sheen>1</sheen></velvet>",
        "<emission></emission>",
        "<microfacet><alpha>0.1</alpha></microfacet>",
    ] {
        // A red diffuse colour, so a record silently ignored would show.
        let text = edits(&[
            (
                "<color>0.5 0.5 0.5 1</color>",
                "<color>0.9 0.1 0.1 1</color>",
            ),
            (
                "    </effect>",
                &format!(
                    r#"      <extra><technique profile="CGL">{record}</technique></extra>
    </effect>"#
                ),
            ),
        ]);
        let scene = load_str(&text, Path::new(NAME)).unwrap_or_else(|e| panic!("{record}: {e}"));
        let mat = scene
            .materials
            .iter()
            .find(|m| m.name != "default")
            .unwrap();
        assert_eq!(mat.material, wavepath::scene::Material::DEFAULT, "{record}");
        assert!(
            scene.warnings.iter().any(|w| w.contains("grey diffuse")),
            "{record}: {:?}",
            scene.warnings
        );
    }
    let text = edit(
        "    </effect>",
        r#"      <extra><technique profile="CGL"><emission><radiance>1 -2 1</radiance></emission></technique></extra>
    </effect>"#,
    );
    let e = load_err(&text);
    assert_eq!(e.element.as_deref(), Some("radiance"), "{e}");
    assert!(e.message.contains("negative"), "{e}");
}

/// Numbers a material record holds are checked as the diffuse colour is,
/// though the record itself is not rendered yet (its fallback albedo comes
/// from them): no negative reflectance, transmittance, roughness or k, no
/// alpha, ior or eta of 0 or less; a reflectance above 1 is kept with a
/// warning.
#[test]
fn material_records_hold_physical_numbers() {
    let with_record = |record: &str| {
        edit(
            "    </effect>",
            &format!(
                r#"      <extra><technique profile="CGL">{record}</technique></extra>
    </effect>"#
            ),
        )
    };
    let metal = "<eta>0.2 0.9 1.1</eta><k>3.9 2.4 2.2</k>";
    for (record, element, words) in [
        (
            "<mirror><reflectance>1 -1 1</reflectance></mirror>".to_string(),
            "reflectance",
            "negative component",
        ),
        (
            "<glass><transmittance>-1 1 1</transmittance></glass>".into(),
            "transmittance",
            "negative component",
        ),
        (
            "<glass><roughness>-0.1</roughness></glass>".into(),
            "roughness",
            "must not be negative",
        ),
        (
            "<refraction><ior>0</ior></refraction>".into(),
            "ior",
            "must be positive",
        ),
        (
            format!("<microfacet><alpha>0</alpha>{metal}</microfacet>"),
            "alpha",
            "must be positive",
        ),
        (
            "<microfacet><eta>0.2 -0.9 1.1</eta><k>1 1 1</k></microfacet>".into(),
            "eta",
            "must be positive",
        ),
        (
            "<microfacet><eta>0.2 0.9 1.1</eta><k>1 -1 1</k></microfacet>".into(),
            "k",
            "negative component",
        ),
    ] {
        let e = load_err(&with_record(&record));
        assert_eq!(e.element.as_deref(), Some(element), "{record}: {e}");
        assert!(e.message.contains(words), "{record}: {e}");
    }
    // k = 0 (no absorption) and roughness 0 (smooth) are physical.
    for record in [
        "<microfacet><eta>1.5 1.5 1.5</eta><k>0 0 0</k></microfacet>",
        "<glass><roughness>0</roughness></glass>",
    ] {
        load_str(&with_record(record), Path::new(NAME)).unwrap_or_else(|e| panic!("{record}: {e}"));
    }
    let text = with_record("<mirror><reflectance>1 3e38 1</reflectance></mirror>");
    let scene = load_str(&text, Path::new(NAME)).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("reflectance has a component of 3e38: above 1")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn clipping_planes_are_checked_against_the_defaults_of_the_one_not_given() {
    // A lone <znear> past the default zfar (1000), a lone <zfar> short of
    // the default znear (0.001), a negative one: each would clip every ray.
    for (near, far, words) in [
        ("<znear>5000</znear>", "", "zfar 1000 (the default)"),
        ("", "<zfar>0.0005</zfar>", "znear 0.001 (the default)"),
        ("", "<zfar>-1</zfar>", "must satisfy"),
        // Equal planes leave no depth at all.
        (
            "<znear>2</znear>",
            "<zfar>2</zfar>",
            "must satisfy 0 ≤ znear < zfar",
        ),
    ] {
        let text = edits(&[
            ("<znear>0.1</znear>", near),
            ("<zfar>100</zfar>", far),
            ("<perspective>", "<perspective> <!-- here -->"),
        ]);
        expect_at(&text, "perspective", "<!-- here -->", words);
    }
}

#[test]
fn comments_inside_numbers_are_skipped_not_taken_for_the_end() {
    let base = load_str(BASE, Path::new(NAME)).unwrap();
    // The triangle's index list and the sphere's radius, each split by a
    // comment: the same scene as without the comments.
    let text = edits(&[
        (
            "<p>0 0 0 1 0 1 2 0 2</p>",
            "<p>0 0 0 1 0 <!-- c -->1 2 0 2</p>",
        ),
        ("<radius>0.5</radius>", "<radius><!-- r -->0.5</radius>"),
        (
            r#"count="9">0 0 0 1 0 0 0 1 0"#,
            r#"count="9">0 0 0 1<!-- x -->0 0 0 0 1 0"#,
        ),
    ]);
    let scene = load_str(&text, Path::new(NAME)).unwrap();
    let (a, b) = (&base.geometry, &scene.geometry);
    assert_eq!(b.triangles.indices, a.triangles.indices);
    assert_eq!(b.spheres.radius, a.spheres.radius);
    // "1<!-- x -->0" is the number 10, as XML reads it.
    assert_eq!(
        b.triangles.positions.len(),
        a.triangles.positions.len(),
        "{:?}",
        b.triangles.positions
    );
    assert_ne!(b.triangles.positions, a.triangles.positions);
    // An element among numbers is an error, not silently skipped.
    case(
        "<p>0 0 0 1 0 1 2 0 2</p>",
        "<p>0 0 0 1 0 1 <q/> 2 0 2</p>",
        "p",
        "<q> where only numbers belong",
    );
}

#[test]
fn instancing_to_more_primitives_than_the_renderer_takes_is_refused_up_front() {
    // A chain of 19 nodes, each instancing the next twice, ends in a node
    // with 129 instances: 2^19 · 129 > 2^26 triangles, spheres or (two
    // triangles each) area lights from a few kilobytes, within the
    // node-visit limit (2^20). The count comes first, with nothing built.
    for leaf in [
        r##"<instance_geometry url="#tri"/>"##,
        r##"<instance_geometry url="#ball"/>"##,
        r##"<instance_light url="#lamp"/>"##,
    ] {
        // The instances sit in a plain child node of the chain's end,
        // which the count must enter too.
        let text = with_doubling_chain(19, &format!("<node>{}</node>", leaf.repeat(129)));
        let e = expect_at(
            &text,
            "visual_scene",
            r#"<visual_scene id="world">"#,
            "primitives, more than the 67108864 (2^26)",
        );
        assert!(!e.message.contains("node instances"), "{leaf}: {e}");
    }
}

#[test]
fn repeated_ids_huge_scenes_empty_scenes_and_bright_albedos_are_warned_about() {
    let warnings = |text: &str| load_str(text, Path::new(NAME)).unwrap().warnings;
    let has = |w: &[String], words: &str| w.iter().any(|w| w.contains(words));
    // An id two elements have, which a reference uses: said once, at the
    // element the reference reaches.
    let text = edit(
        "  </library_materials>",
        "    <material id=\"mat\" name=\"again\"><instance_effect url=\"#fx\"/></material>\n  </library_materials>",
    );
    let w = warnings(&text);
    let line = line_of(&text, "name=\"again\"");
    assert_eq!(
        w,
        [format!(
            "{NAME}:{line}: 2 elements have the id \"mat\"; references to it reach this last one"
        )]
    );
    // One that nothing refers to (the CS184 scenes name many nodes alike).
    let w = warnings(&edit(
        r#"<node id="camera-node">"#,
        r#"<node id="lamp-node">"#,
    ));
    assert!(w.is_empty(), "{w:?}");
    let w = warnings(&edit(
        r#"count="9">0 0 0 1 0 0 0 1 0"#,
        r#"count="9">0 0 0 1e13 0 0 0 1e13 0"#,
    ));
    assert!(has(&w, "coordinates reach 1e13"), "{w:?}");
    let w = warnings(&edits(&[
        (
            r##"<instance_geometry url="#tri">"##,
            r##"<instance_light url="#lamp">"##,
        ),
        (
            r##"<instance_geometry url="#ball">"##,
            r##"<instance_light url="#lamp">"##,
        ),
        (
            "        </instance_geometry>\n      </node>\n      <node id=\"ball-node\">",
            "        </instance_light>\n      </node>\n      <node id=\"ball-node\">",
        ),
        (
            "        </instance_geometry>\n      </node>\n    </visual_scene>",
            "        </instance_light>\n      </node>\n    </visual_scene>",
        ),
    ]));
    assert!(has(&w, "no geometry"), "{w:?}");
    let w = warnings(&edit(
        "<color>0.5 0.5 0.5 1</color>",
        "<color>0.5 1.5 0.5 1</color>",
    ));
    assert!(has(&w, "component of 1.5: above 1"), "{w:?}");
    // None of these for the base scene.
    assert!(warnings(BASE).is_empty());
}

#[test]
fn pipes_are_read_and_devices_refused() {
    // `wavepath <(zcat scene.dae.gz)`: a named pipe with a writer loads.
    let fifo = scratch().join("scene.fifo");
    let _ = std::fs::remove_file(&fifo);
    let made = Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("skipped: mkfifo is not available here");
        return;
    }
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::write(fifo, BASE).unwrap())
    };
    let scene = load_file(&fifo).unwrap();
    writer.join().unwrap();
    assert_eq!(scene.geometry.triangles.len(), 1);
    std::fs::remove_file(&fifo).unwrap();
    // A device that never ends is refused rather than read until memory
    // runs out.
    let zero = Path::new("/dev/zero");
    if zero.exists() {
        let e = load_file(zero).unwrap_err();
        assert!(e.to_string().contains("not a scene file"), "{e}");
    }
}
