//! Shared helpers for the integration tests: the shared test data, tiny glTF files written in
//! code, and running the binary.
#![allow(dead_code)]

pub mod gltf_builder;

use std::path::PathBuf;

/// `../shared/<sub>`, the test data beside the checkout (not part of the repository). Tests
/// that need it are `#[ignore = "needs ../shared"]`: a fresh clone's `cargo test` counts them
/// as ignored, and `scripts/test.sh` runs them (`--include-ignored`) when ../shared is there.
/// A test that asks for a file that is absent fails with a message, never passes silently.
pub fn shared(sub: &str) -> PathBuf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("shared").join(sub);
    assert!(p.exists(), "{} is absent: this test needs the shared test data beside the checkout", p.display());
    p
}

pub fn model(name: &str) -> PathBuf {
    shared(&format!("models/{name}"))
}

/// The built-in icosphere (`levels` subdivisions; 3 = the thesis's 1280-face sphere of Table
/// 4.1) as a .gltf file in `dir`.
pub fn icosphere_gltf(dir: &std::path::Path, levels: u32) -> PathBuf {
    let m = cubist::scene::default::icosphere("icosphere", levels, 1.0, 0);
    let mut g = gltf_builder::Gltf::default();
    let p: Vec<f32> = m.positions.iter().flat_map(|v| v.to_array()).collect();
    let n: Vec<f32> = m.normals.iter().flat_map(|v| v.to_array()).collect();
    let pos = g.floats(&p, 3, true);
    let nrm = g.floats(&n, 3, false);
    let idx: Vec<u32> = m.triangles.iter().flatten().copied().collect();
    let idx = g.indices(&idx);
    let mesh = g.mesh(serde_json::json!({"POSITION": pos, "NORMAL": nrm}), Some(idx), 4, None);
    let node = g.node(serde_json::json!({"mesh": mesh}));
    g.scene_nodes.push(node);
    g.write(dir, "icosphere.gltf")
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
