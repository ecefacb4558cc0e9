//! The small valid scene that loader tests edit, and the edits.
//!
//! Each loader test is a targeted edit of [`BASE`], so a case tests
//! exactly one thing.

/// A minimal valid scene: Y_UP, a camera, a point light, one effect and
/// material, one textured triangle (a `<polylist>`) and one CGL sphere.
/// Errors report lines of this text: `fixtures/minimal.dae` line for line.
pub const BASE: &str = include_str!("../fixtures/minimal.dae");

/// The fixture's position accessor, which edits remove to leave a packed
/// source.
pub const POSITION_ACCESSOR: &str = r##"<technique_common>
            <accessor source="#tri-pos-array" count="3" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>"##;

/// The name errors report for scenes loaded from strings.
pub const NAME: &str = "scenes/bad.dae";

/// `text` with each `from` (which must occur exactly once) replaced by its `to`.
pub fn edit_text(text: &str, pairs: &[(&str, &str)]) -> String {
    let mut out = text.to_string();
    for &(from, to) in pairs {
        let n = out.matches(from).count();
        assert_eq!(n, 1, "{from:?} occurs {n} times, expected exactly once");
        out = out.replacen(from, to, 1);
        assert!(out.contains(to));
    }
    assert_ne!(out, text, "the edits changed nothing");
    out
}

/// [`BASE`] with the given edits.
pub fn edits(pairs: &[(&str, &str)]) -> String {
    edit_text(BASE, pairs)
}

/// [`BASE`] with `from` replaced by `to`.
pub fn edit(from: &str, to: &str) -> String {
    edits(&[(from, to)])
}

/// 1-based line of the one occurrence of `needle` in `text`.
pub fn line_of(text: &str, needle: &str) -> u32 {
    let n = text.matches(needle).count();
    assert_eq!(
        n, 1,
        "marker {needle:?} occurs {n} times, expected exactly once"
    );
    let at = text.find(needle).unwrap();
    text[..at].matches('\n').count() as u32 + 1
}
