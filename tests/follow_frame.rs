//! One frame whose facets follow a key frame saved beside its layout (`cubist render SCENE
//! --facet-motion follow --facets LAYOUT`): the route of the Blender add-on, which renders each
//! frame of an animation in its own process from its own exported scene. The key frame saves
//! its layout and follow data; any other process renders a frame from them, byte for byte the
//! same wherever it runs; bad or mismatched follow data is a one-line error, never a panic.

mod common;

use std::path::{Path, PathBuf};

use common::gltf_builder::Gltf;
use common::{binary, run};
use serde_json::json;

/// Two icospheres (2 subdivisions each) and a light; `shift` moves the second sphere and turns
/// it (the same triangles, posed elsewhere: another frame of an animation). `levels` of the
/// second sphere changes its triangle count.
fn spheres(dir: &Path, name: &str, shift: f32, levels: u32) -> PathBuf {
    let mut g = Gltf::default();
    for (i, lv) in [2, levels].into_iter().enumerate() {
        let m = cubist::scene::default::icosphere("sphere", lv, 1.0, 0);
        let p: Vec<f32> = m.positions.iter().flat_map(|v| v.to_array()).collect();
        let n: Vec<f32> = m.normals.iter().flat_map(|v| v.to_array()).collect();
        let pos = g.floats(&p, 3, true);
        let nrm = g.floats(&n, 3, false);
        let idx: Vec<u32> = m.triangles.iter().flatten().copied().collect();
        let idx = g.indices(&idx);
        let mesh = g.mesh(json!({"POSITION": pos, "NORMAL": nrm}), Some(idx), 4, None);
        let (x, turn) = if i == 0 { (-1.2, 0.0f32) } else { (1.2 + shift, shift) };
        let (s, c) = (turn * 0.5).sin_cos();
        let node = g.node(json!({"mesh": mesh, "translation": [x, 0.0, 0.0], "rotation": [0.0, s, 0.0, c]}));
        g.scene_nodes.push(node);
    }
    g.write(dir, name)
}

const SIZE: [&str; 4] = ["--width", "96", "--height", "72"];

fn render(dir: &Path, scene: &Path, extra: &[&str], out: &str) -> (i32, String) {
    let mut args = vec!["render", scene.to_str().unwrap(), "-o", out, "--facet-motion", "follow"];
    args.extend_from_slice(&SIZE);
    args.extend_from_slice(extra);
    let (code, _, err) = run(dir, &args);
    (code, err)
}

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn a_frame_rendered_from_the_saved_key_is_the_same_in_every_process() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = spheres(d, "key.gltf", 0.0, 2);
    let posed = spheres(d, "posed.gltf", 0.35, 2);

    // The key frame computes and saves its layout and follow data.
    let (code, err) = render(d, &key, &["--save-facets", "layout.json"], "key.png");
    assert_eq!(code, 0, "{err}");
    assert!(d.join("layout.json").is_file() && d.join("layout.json.follow").is_file());
    // The key frame rendered again from what it saved: the same picture.
    let (code, err) = render(d, &key, &["--facets", "layout.json"], "key_again.png");
    assert_eq!(code, 0, "{err}");
    assert_eq!(bytes(&d.join("key.png")), bytes(&d.join("key_again.png")));

    // Another frame, twice (two processes) and on one thread: byte for byte the same.
    let pass = ["--facets", "layout.json", "--pass", "facet-ids"];
    let (code, err) = render(d, &posed, &pass, "a.png");
    assert_eq!(code, 0, "{err}");
    let (code, err) = render(d, &posed, &pass, "b.png");
    assert_eq!(code, 0, "{err}");
    let one_thread = std::process::Command::new(binary())
        .args(["render", posed.to_str().unwrap(), "-o", "c.png", "--facet-motion", "follow"])
        .args(SIZE)
        .args(pass)
        .env("RAYON_NUM_THREADS", "1")
        .current_dir(d)
        .output()
        .unwrap();
    assert!(one_thread.status.success(), "{}", String::from_utf8_lossy(&one_thread.stderr));
    let a = bytes(&d.join("a.png"));
    assert_eq!(a, bytes(&d.join("b.png")));
    assert_eq!(a, bytes(&d.join("c.png")));
    assert_ne!(a, bytes(&d.join("key.png")), "the posed frame shows the moved sphere");

    // The facets moved with the sphere: static facets (the layout as it is) differ.
    let mut args = vec!["render", posed.to_str().unwrap(), "-o", "static.png", "--facet-motion", "static"];
    args.extend_from_slice(&SIZE);
    args.extend_from_slice(&pass);
    let (code, _, err) = run(d, &args);
    assert_eq!(code, 0, "{err}");
    let ids = |name: &str| image::open(d.join(name)).unwrap().into_luma16().into_raw();
    let (follow, fixed) = (ids("a.facet-ids.png"), ids("static.facet-ids.png"));
    let changed = follow.iter().zip(&fixed).filter(|(a, b)| a != b).count();
    assert!(changed > follow.len() / 100, "facets did not follow the sphere: {changed} pixels changed facet");
}

/// One line on stderr, exit 2 (a setting's error), no picture, no panic.
fn refused(dir: &Path, scene: &Path, extra: &[&str], needle: &str) {
    let out = dir.join("refused.png");
    let (code, err) = render(dir, scene, extra, "refused.png");
    assert_eq!(code, 2, "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.starts_with("error: ") && err.contains(needle), "{err}");
    assert!(!out.exists(), "a picture was written");
}

#[test]
fn bad_or_mismatched_follow_data_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let key = spheres(d, "key.gltf", 0.0, 2);
    let (code, err) = render(d, &key, &["--save-facets", "layout.json"], "key.png");
    assert_eq!(code, 0, "{err}");
    let good = bytes(&d.join("layout.json.follow"));

    // Another mesh (a sphere of fewer triangles): triangles no longer correspond.
    let other = spheres(d, "other.gltf", 0.0, 1);
    refused(d, &other, &["--facets", "layout.json"], "triangles");
    // Another image size than the key frame's.
    let mut args = vec!["render", key.to_str().unwrap(), "-o", "refused.png", "--facet-motion", "follow"];
    args.extend_from_slice(&["--width", "64", "--height", "48", "--facets", "layout.json"]);
    let (code, _, err) = run(d, &args);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("follow data is 96x72"), "{err}");

    // Damaged follow data.
    let damaged = d.join("layout.json.follow");
    std::fs::write(&damaged, &good[..good.len() - 4]).unwrap();
    refused(d, &key, &["--facets", "layout.json"], "bytes where its header announces");
    std::fs::write(&damaged, b"not follow data at all").unwrap();
    refused(d, &key, &["--facets", "layout.json"], "not cubist follow data");
    let mut wrong_triangle = good.clone();
    let n = wrong_triangle.len();
    // The last pixel's depth made negative (its sign bit).
    wrong_triangle[n - 1] |= 0x80;
    std::fs::write(&damaged, &wrong_triangle).unwrap();
    refused(d, &key, &["--facets", "layout.json"], "has depth");

    // No follow data beside the layout (saved with static facets, or deleted).
    std::fs::remove_file(&damaged).unwrap();
    refused(d, &key, &["--facets", "layout.json"], "has no follow data beside it");
}
