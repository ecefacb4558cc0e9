//! Mutation test of the COLLADA loader: thousands of randomly damaged copies
//! of valid scenes must each load or fail cleanly, never panic; and whatever
//! loads must be safe to render (indices in range, finite geometry).
//!
//! The generator is a fixed-seed xorshift, so every run tests the same inputs;
//! a failing input is saved under the target's tmp directory.

use std::panic::catch_unwind;
use std::path::{Path, PathBuf};

use wavepath::scene::Scene;
use wavepath::scene::collada::load_str;

/// The minimal valid scene of `tests/bad_input.rs`.
const BASE: &str = include_str!("fixtures/minimal.dae");

/// What a number token is replaced with.
const NUMBERS: [&str; 13] = [
    "nan",
    "-1",
    "1e39",
    "99999999",
    "",
    "0",
    "-0",
    "inf",
    "1e-45",
    "3e38",
    "4294967295",
    "18446744073709551615",
    "18446744073709551616",
];

/// xorshift64* (Vigna): tiny, fast and good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// Uniform-ish in `0..n` (`n > 0`).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Byte ranges of the number tokens of `text` (`-1.5e3`, `.3`, `9`), not
/// counting digits inside names like `Area_001`.
fn number_tokens(text: &[u8]) -> Vec<(usize, usize)> {
    let is_name = |b: u8| b.is_ascii_alphanumeric() || b == b'_';
    let is_num = |b: u8| b.is_ascii_digit() || matches!(b, b'.' | b'-' | b'+' | b'e' | b'E');
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let starts = (text[i].is_ascii_digit() || matches!(text[i], b'-' | b'.'))
            && (i == 0 || !is_name(text[i - 1]));
        if !starts {
            i += 1;
            continue;
        }
        let mut j = i + 1;
        while j < text.len() && is_num(text[j]) {
            j += 1;
        }
        let digits = text[i..j].iter().any(u8::is_ascii_digit);
        if digits && (j == text.len() || !is_name(text[j])) {
            out.push((i, j));
        }
        i = j;
    }
    out
}

/// One random mutation of `bytes`.
fn mutate(rng: &mut Rng, bytes: &mut Vec<u8>) {
    let len = bytes.len();
    // A short range (up to 256 bytes) starting in the text.
    let range = |rng: &mut Rng| {
        let start = rng.below(len + 1);
        let n = rng.below((len - start).min(256) + 1);
        start..start + n
    };
    match rng.below(12) {
        // Flip one bit (may break UTF-8, tags, names or numbers).
        0 | 1 if len > 0 => {
            let i = rng.below(len);
            bytes[i] ^= 1 << rng.below(8);
        }
        // Truncate.
        2 => bytes.truncate(rng.below(len + 1)),
        // Delete a range.
        3 | 4 => {
            bytes.drain(range(rng));
        }
        // Duplicate a range in place.
        5 | 6 => {
            let r = range(rng);
            let copy = bytes[r.clone()].to_vec();
            bytes.splice(r.end..r.end, copy);
        }
        // Replace a number with a bad or extreme one.
        _ => {
            let tokens = number_tokens(bytes);
            if !tokens.is_empty() {
                let (a, b) = tokens[rng.below(tokens.len())];
                let with = NUMBERS[rng.below(NUMBERS.len())];
                bytes.splice(a..b, with.bytes());
            }
        }
    }
}

/// What a scene that loaded must satisfy for the renderer to be safe.
fn check(scene: &Scene) -> Result<(), String> {
    let t = &scene.geometry.triangles;
    let s = &scene.geometry.spheres;
    let materials = scene.materials.len();
    if t.material.len() != t.indices.len() || t.normals.len() != t.positions.len() {
        return Err("triangle arrays disagree in length".into());
    }
    if !(t.texcoords.is_empty() || t.texcoords.len() == t.indices.len()) {
        return Err("texcoords disagree with the triangle count".into());
    }
    if let Some(tri) = t
        .indices
        .iter()
        .find(|tri| tri.iter().any(|&i| i as usize >= t.positions.len()))
    {
        return Err(format!(
            "triangle {tri:?} indexes past {} positions",
            t.positions.len()
        ));
    }
    if let Some(p) = t.positions.iter().find(|p| !p.is_finite()) {
        return Err(format!("non-finite position {p}"));
    }
    if let Some(n) = t.normals.iter().find(|n| !n.is_finite()) {
        return Err(format!("non-finite normal {n}"));
    }
    if s.center.len() != s.radius.len() || s.material.len() != s.radius.len() {
        return Err("sphere arrays disagree in length".into());
    }
    if let Some(r) = s.radius.iter().find(|r| !(r.is_finite() && **r > 0.0)) {
        return Err(format!("sphere radius {r} is not positive and finite"));
    }
    if let Some(c) = s.center.iter().find(|c| !c.is_finite()) {
        return Err(format!("non-finite sphere centre {c}"));
    }
    if let Some(m) = t
        .material
        .iter()
        .chain(&s.material)
        .find(|&&m| m as usize >= materials)
    {
        return Err(format!("material {m} of {materials}"));
    }
    Ok(())
}

/// Saves a failing input and returns where it went.
fn save(name: &str, case: usize, text: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("loader_fuzz");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{}-{case}.dae", name.replace('/', "_")));
    std::fs::write(&path, text).unwrap();
    path
}

/// Loads `cases` mutants of `text` (1–3 mutations each), seeded by `seed`.
fn fuzz(name: &str, text: &str, cases: usize, seed: u64) {
    let path = PathBuf::from(name);
    let original = load_str(text, &path).unwrap_or_else(|e| panic!("the original fails: {e}"));
    check(&original).unwrap_or_else(|e| panic!("the original fails the checks: {e}"));

    let mut rng = Rng(seed);
    let (mut ok, mut err) = (0, 0);
    for case in 0..cases {
        let mut bytes = text.as_bytes().to_vec();
        for _ in 0..1 + rng.below(3) {
            mutate(&mut rng, &mut bytes);
        }
        let mutant = String::from_utf8_lossy(&bytes);
        match catch_unwind(|| load_str(&mutant, &path)) {
            Err(_) => panic!(
                "the loader panicked on mutant {case}, saved as {}",
                save(name, case, &mutant).display()
            ),
            Ok(Ok(scene)) => {
                if let Err(why) = check(&scene) {
                    panic!(
                        "mutant {case} loaded but {why}; saved as {}",
                        save(name, case, &mutant).display()
                    );
                }
                ok += 1;
            }
            Ok(Err(e)) => {
                // Errors are located and one line long.
                let shown = e.to_string();
                assert!(shown.starts_with(name), "{shown}");
                assert!(!shown.contains('\n'), "multi-line error: {shown:?}");
                err += 1;
            }
        }
    }
    eprintln!("{name}: {cases} mutants: {ok} loaded (Ok), {err} rejected (Err)");
}

#[test]
fn mutants_of_the_minimal_scene() {
    fuzz("minimal.dae", BASE, 20_000, 0x9e37_79b9_7f4a_7c15);
}

#[test]
fn mutants_of_cs184_scenes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/cs184");
    for (i, rel) in ["sky/CBspheres_lambertian.dae", "basic/sphere_diffuse.dae"]
        .into_iter()
        .enumerate()
    {
        let path = dir.join(rel);
        let Ok(text) = std::fs::read_to_string(&path) else {
            eprintln!("skipping {}: absent", path.display());
            continue;
        };
        fuzz(rel, &text, 8000, 0x5eed + i as u64);
    }
}

#[test]
fn number_tokens_are_found() {
    let text = br#"<a id="Area_001" count="3">-1.5e3 .3 9 x2</a>"#;
    let tokens: Vec<&[u8]> = number_tokens(text)
        .into_iter()
        .map(|(a, b)| &text[a..b])
        .collect();
    assert_eq!(tokens, [&b"3"[..], b"-1.5e3", b".3", b"9"]);
}
