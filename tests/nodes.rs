//! Farm nodes that differ agree: the same frames, byte for byte, whatever the node's core count
//! (`RAYON_NUM_THREADS` 1 and 2) and whether its run-time SIMD paths run or are forced off
//! (`CUBIST_NO_SIMD=1`, docs/farm.md). Clustered saliency is asked for so that its AVX2 kernels
//! (`saliency::kernels`) run on every frame's meshes; `--verbose` says which path they took.
//!
//! The test marked `needs ../shared` reads an animated glTF sample of ../shared
//! (`cargo test --release --test nodes -- --include-ignored`).

use std::path::{Path, PathBuf};
use std::process::Command;

/// How a node runs `cubist`: its thread count and whether SIMD is forced off.
#[derive(Clone, Copy, Debug)]
struct Node {
    threads: usize,
    no_simd: bool,
}

const NODES: [Node; 4] = [
    Node { threads: 2, no_simd: false },
    Node { threads: 1, no_simd: false },
    Node { threads: 2, no_simd: true },
    Node { threads: 1, no_simd: true },
];

/// Renders `args` (a `--frames` run) into a fresh folder as `node`; returns the frames' bytes
/// in order of their names.
fn render_on(node: Node, dir: &Path, args: &[&str]) -> Vec<(String, Vec<u8>)> {
    let out = dir.join(format!("threads{}-nosimd{}", node.threads, node.no_simd as u8));
    let pattern = out.join("f_####.png");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubist"));
    cmd.arg("render").args(args).arg("-o").arg(&pattern).args(["--progress", "none", "--verbose"]);
    cmd.env("RAYON_NUM_THREADS", node.threads.to_string()).env_remove("CUBIST_NO_SIMD");
    if node.no_simd {
        cmd.env("CUBIST_NO_SIMD", "1");
    }
    let r = cmd.output().unwrap();
    let said = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{node:?}: cubist render {args:?} failed: {said}");
    // The path the kernels took, as `--verbose` reports it.
    let kernels = said.lines().find_map(|l| l.strip_prefix("kernels: ")).unwrap_or_default();
    let expected = if node.no_simd {
        "baseline (CUBIST_NO_SIMD)"
    } else if avx2_here() {
        "avx2"
    } else {
        "baseline (no AVX2 on this CPU)"
    };
    assert_eq!(kernels, expected, "{node:?}");
    let mut frames: Vec<(String, Vec<u8>)> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap())
        })
        .collect();
    frames.sort();
    frames
}

fn avx2_here() -> bool {
    #[cfg(target_arch = "x86_64")]
    let detected = std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    let detected = false;
    detected
}

/// Every node's frames equal the first node's, byte for byte; the frames differ (something moved).
fn nodes_agree(args: &[&str], expected: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let first = render_on(NODES[0], dir.path(), args);
    let names: Vec<&str> = first.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, expected);
    assert_ne!(first[0].1, first[1].1, "{args:?}: the frames are the same picture");
    for node in &NODES[1..] {
        let other = render_on(*node, dir.path(), args);
        assert_eq!(other.len(), first.len(), "{node:?}");
        for ((name, a), (_, b)) in first.iter().zip(&other) {
            assert!(a == b, "{args:?}: {name} on {node:?} differs from {:?}'s", NODES[0]);
        }
    }
}

#[test]
fn a_still_life_turntable_is_the_same_on_every_node() {
    let args =
        ["--frames", "1-2", "--orbit", "20", "--width", "96", "--height", "72", "--saliency-method", "clustered"];
    nodes_agree(&args, &["f_0001.png", "f_0002.png"]);
}

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared").join(rel)
}

#[test]
#[ignore = "needs ../shared"]
fn a_walking_fox_is_the_same_on_every_node() {
    let fox = shared("gltf-samples/Fox.glb");
    let fox = fox.to_str().unwrap();
    let args = [
        fox,
        "--animation",
        "Walk",
        "--fps",
        "8",
        "--frames",
        "2-3",
        "--width",
        "96",
        "--height",
        "80",
        "--saliency-method",
        "clustered",
    ];
    nodes_agree(&args, &["f_0002.png", "f_0003.png"]);
}
