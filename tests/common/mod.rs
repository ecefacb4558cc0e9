//! Shared helpers for the integration tests.
#![allow(dead_code)]

pub mod fixture;
pub mod mesh;
pub mod render;

use std::path::PathBuf;

/// `../shared/scenes/cs184` beside the repository, if present.
///
/// The CS184 scenes are test data that live outside the repository; on a
/// clone without them, tests that need them print why they skip.
pub fn cs184_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/cs184");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "skipping: {} is absent (the CS184 scenes are read from ../shared beside the repository)",
            dir.display()
        );
        None
    }
}

/// A CS184 scene by relative path, e.g. `sky/CBbunny.dae`.
pub fn cs184_scene(rel: &str) -> Option<PathBuf> {
    cs184_dir().map(|d| d.join(rel))
}

/// `../shared/scenes/malformed` beside the repository, if present.
pub fn malformed_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes/malformed");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping: {} is absent", dir.display());
        None
    }
}

/// Every `.dae` file below `dir`, sorted.
pub fn dae_files(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "dae") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}
