//! Shared helpers for the integration tests: the shared test data, tiny glTF files written in
//! code, and running the binary.
#![allow(dead_code)]

pub mod gltf_builder;

use std::path::PathBuf;

/// `../shared` beside the checkout, or None (with a message) on a user's fresh clone.
pub fn shared(sub: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("shared").join(sub);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipped: {} is absent (the shared test data is not part of the repository)", p.display());
        None
    }
}

pub fn model(name: &str) -> Option<PathBuf> {
    shared(&format!("models/{name}"))
}

pub fn binary() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_cubist"))
}

/// Runs the binary in `dir`, returning (exit code, stdout, stderr).
pub fn run(dir: &std::path::Path, args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(binary()).args(args).current_dir(dir).output().expect("run cubist");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
