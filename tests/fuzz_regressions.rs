//! Malformed input that once crashed, hung or exhausted memory, kept as regression tests
//!. Files found by the fuzzers (scripts/fuzz.sh) live in
//! tests/fuzz_regressions/<target>/, and every fuzz seed (fuzz/seeds/<target>/) runs too;
//! inputs too large to keep as files are generated here. Each must give a clean one-line
//! `Err` or a scene every later stage takes, within a watchdog's time, never a panic.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use base64::Engine;
use cubist::pipeline::{Prepared, render};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::{Preset, Settings};
use serde_json::{Map, Value, json};

fn within<T: Send + 'static>(secs: u64, what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        // The size of a render thread's stack, not the main thread's 8 MB: a loader that
        // recursed once per nested node overflowed it.
        .stack_size(2 << 20)
        .spawn(move || {
            let _ = tx.send(f());
        })
        .unwrap();
    match rx.recv_timeout(Duration::from_secs(secs)) {
        Ok(v) => v,
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("{what}: still running after {secs} s (a hang?)"),
        Err(mpsc::RecvTimeoutError::Disconnected) => panic!("{what}: panicked"),
    }
}

/// The inputs of a fuzz target kept in the repository: its crashes (tests/fuzz_regressions/
/// <target>, when it has any) and its seeds (fuzz/seeds/<target>). Never empty: a test over
/// no input would pass without running.
fn regression_files(target: &str) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = Vec::new();
    for dir in [root.join("tests/fuzz_regressions").join(target), root.join("fuzz/seeds").join(target)] {
        if let Ok(entries) = std::fs::read_dir(&dir) {
            files.extend(entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file()));
        }
    }
    files.sort();
    assert!(!files.is_empty(), "no input for the {target} fuzz target: the test would run zero cases");
    files
}

/// What the gltf_loader fuzz target does with an input, made strict: the loader's own
/// panic guard ("the parser failed") counts as a failure too.
fn load_and_render(bytes: Vec<u8>, what: String) -> Result<(), String> {
    within(60, &what.clone(), move || {
        let scene = match Scene::from_slice(&bytes) {
            Ok(s) => s,
            Err(e) => {
                let msg = e.to_string();
                assert!(!msg.contains('\n'), "{what}: error of several lines: {msg}");
                assert!(!msg.contains("the parser failed"), "{what}: the loader panicked (caught): {msg}");
                return Err(msg);
            }
        };
        let prep = Prepared::new(scene);
        let mut s = Settings::preset(Preset::Plain);
        s.width = 8;
        s.height = 6;
        s.spp = 1;
        let r = render(&prep, &s, &Progress::silent()).map_err(|e| e.to_string())?;
        assert!(r.film.color.iter().all(|c| c.is_finite()), "{what}: NaN pixel");
        Ok(())
    })
}

#[test]
fn gltf_loader_regressions() {
    let files = regression_files("gltf_loader");
    let mut loaded = 0;
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let r = load_and_render(bytes, f.display().to_string());
        eprintln!("{}: {r:?}", f.display());
        loaded += r.is_ok() as usize;
    }
    // The seeds are valid scenes: most of them must load and render.
    assert!(files.len() > 10 && loaded * 2 > files.len(), "{loaded} of {} inputs rendered", files.len());
}

#[test]
fn settings_json_regressions() {
    let files = regression_files("settings_json");
    let mut cases = 0;
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let what = f.display().to_string();
        // Not JSON at all: refused before the settings see it, as the fuzz target does.
        let Ok(value) = serde_json::from_slice::<Value>(&bytes) else { continue };
        cases += 1;
        within(30, &what.clone(), move || {
            for layer in [Some(value.clone()), None] {
                let r = match (&layer, &value) {
                    (Some(v), _) => Settings::from_layers(Some((Path::new("fuzz.json"), v.clone())), Map::new()),
                    (None, Value::Object(flags)) => Settings::from_layers(None, flags.clone()),
                    (None, _) => continue,
                };
                match r {
                    Ok(s) => s.validate().unwrap_or_else(|e| panic!("{what}: accepted settings fail validation: {e}")),
                    Err(e) => assert!(!e.to_string().contains('\n'), "{what}: {e}"),
                }
            }
        });
    }
    assert!(cases > 5, "only {cases} of {} settings inputs are JSON", files.len());
}

/// The settings_scene target's inputs: settings JSON, a NUL, a glTF document; what
/// the target does, with a watchdog.
#[test]
fn settings_scene_regressions() {
    let files = regression_files("settings_scene");
    let mut rendered = 0;
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let what = f.display().to_string();
        rendered += within(120, &what.clone(), move || {
            let (settings, scene) = match bytes.iter().position(|&b| b == 0) {
                Some(i) => (bytes[..i].to_vec(), bytes[i + 1..].to_vec()),
                None => (bytes.clone(), Vec::new()),
            };
            let Ok(Value::Object(mut map)) = serde_json::from_slice::<Value>(&settings) else { return 0 };
            for (k, max) in [("width", 24u64), ("height", 24), ("spp", 2)] {
                if map.get(k).and_then(Value::as_u64).is_none_or(|v| v > max) {
                    map.insert(k.into(), Value::from(max.min(16)));
                }
            }
            for k in ["facets", "save_facets", "facet_map", "palette_image", "saliency_cache"] {
                map.remove(k);
            }
            let s = match Settings::from_layers(Some((Path::new("fuzz.json"), Value::Object(map))), Map::new()) {
                Ok(s) => s,
                Err(e) => {
                    assert!(!e.to_string().contains('\n'), "{what}: {e}");
                    return 0;
                }
            };
            let prep = if scene.is_empty() {
                Prepared::new(Scene::default_scene())
            } else {
                match Scene::from_slice(&scene) {
                    Ok(sc) => Prepared::new(sc),
                    Err(e) => {
                        assert!(!e.to_string().contains("the parser failed") && !e.to_string().contains('\n'));
                        return 0;
                    }
                }
            };
            match render(&prep, &s, &Progress::silent()) {
                Ok(r) => {
                    assert!(r.film.color.iter().all(|c| c.is_finite()), "{what}: NaN pixel");
                    1
                }
                Err(e) => {
                    assert!(!e.to_string().contains('\n'), "{what}: {e}");
                    0
                }
            }
        });
    }
    assert!(rendered * 2 > files.len(), "{rendered} of {} inputs rendered", files.len());
}

/// The layout_file target's inputs: JSON and PNG layouts, rasterised.
#[test]
fn layout_file_regressions() {
    let files = regression_files("layout_file");
    let mut loaded = 0;
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let what = f.display().to_string();
        loaded += within(60, &what.clone(), move || {
            let layout = if bytes.starts_with(b"\x89PNG") {
                let img = cubist::util::files::decode_image(&bytes, cubist::util::limits::MAX_IMAGE_PIXELS).ok()?;
                cubist::facets::io::from_image(&img, Path::new(&what)).ok()?
            } else {
                cubist::facets::io::from_json(std::str::from_utf8(&bytes).ok()?).ok()?
            };
            for (w, h) in [(17, 11), (64, 48)] {
                let map = layout.rasterize(w, h);
                assert!(map.ids.iter().all(|&id| id < layout.facet_count), "{what}");
            }
            Some(())
        })
        .is_some() as usize;
    }
    assert!(loaded * 2 > files.len(), "{loaded} of {} layouts loaded", files.len());
}

/// Found by the fuzzer (12 bytes: "glTF", version 0, length 0): the gltf crate computed
/// `length - 12` unchecked. Release builds wrapped around into a length error; builds with
/// overflow checks panicked. Now refused up front, by name.
#[test]
fn a_glb_declaring_less_than_its_headers_is_refused() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions/gltf_loader");
    for bytes in [
        std::fs::read(dir.join("glb_declared_length_0.glb")).unwrap(),
        b"glTF\x02\0\0\0\x13\0\0\0".to_vec(),
        b"glTF\x02\0".to_vec(),
    ] {
        let e = Scene::from_slice(&bytes).unwrap_err().to_string();
        assert!(e.contains("declares") || e.contains("truncated GLB"), "{e}");
    }
}

/// A textured one-triangle .gltf whose image is `image` (JSON) over buffer bytes `data`.
fn textured_gltf(image: Value, data: &[u8]) -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    bin.extend_from_slice(data);
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bin));
    let doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 72, "byteLength": data.len()}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"}],
        "images": [image],
        "textures": [{"source": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    });
    serde_json::to_vec(&doc).unwrap()
}

/// Found by the fuzzer (a mutated textured sample): an image in a bufferView without a
/// mimeType, or with neither uri nor bufferView, panicked inside the gltf crate (an unwrap
/// in `Image::source`), reported only as "the parser failed on this file".
#[test]
fn images_without_mimetype_or_source_are_named() {
    let png = [0x89u8, b'P', b'N', b'G'];
    let e = load_and_render(textured_gltf(json!({"bufferView": 2}), &png), "no mimeType".into()).unwrap_err();
    assert!(e.contains("mimeType"), "{e}");
    let e = load_and_render(textured_gltf(json!({}), &png), "no source".into()).unwrap_err();
    assert!(e.contains("neither a uri nor a bufferView"), "{e}");
}

/// Found by the fuzzer (a mutated sample with a JPEG texture): the JPEG decoder's error spans
/// two lines; every error is one line.
#[test]
fn a_corrupt_jpeg_gives_a_one_line_error() {
    let jpeg = [0xFFu8, 0xD8, 0xFF, 0xE0, 0x00, 0x10, b'J', b'F', b'I', b'F', 0x00, 0x01, 0x01, 0x00, 0x00];
    let image = json!({"bufferView": 2, "mimeType": "image/jpeg"});
    let e = load_and_render(textured_gltf(image, &jpeg), "corrupt jpeg".into()).unwrap_err();
    assert!(e.contains("cannot decode") && !e.contains('\n'), "{e}");
}

/// A one-triangle .gltf (data: URI buffer) with `nodes`: node 0 holds the mesh.
fn gltf_with_nodes(nodes: Vec<Value>, roots: Vec<usize>) -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bin));
    let doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteLength": bin.len()}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": nodes,
        "scenes": [{"nodes": roots}],
        "scene": 0,
    });
    serde_json::to_vec(&doc).unwrap()
}

/// Regression: a chain of 20,000 nested nodes (a 0.9 MB file) overflowed the stack (an
/// abort, not even a panic): world transforms were computed recursively.
#[test]
fn a_deep_node_chain_loads() {
    let n = 50_000;
    let nodes: Vec<Value> = (0..n)
        .map(|i| {
            let mut node = json!({"translation": [0.0001, 0.0, 0.0]});
            if i + 1 < n {
                node["children"] = json!([i + 1]);
            }
            if i == n - 1 {
                node["mesh"] = json!(0);
            }
            node
        })
        .collect();
    load_and_render(gltf_with_nodes(nodes, vec![0]), "deep chain".into()).unwrap();
}

/// A node loop deep in a long chain is refused, not followed.
#[test]
fn a_loop_at_the_end_of_a_long_chain_is_refused() {
    let n = 10_000;
    let nodes: Vec<Value> = (0..n).map(|i| json!({"children": [(i + 1) % n], "mesh": 0})).collect::<Vec<_>>();
    let e = load_and_render(gltf_with_nodes(nodes, vec![0]), "loop".into()).unwrap_err();
    assert!(e.contains("appears twice"), "{e}");
}

/// A small file must not expand into unbounded memory by instancing: 600 nodes each placing a
/// mesh of 100,000 triangles (60 M triangles, ~6 GB) from a 0.5 MB file is refused.
#[test]
fn an_instancing_bomb_is_refused() {
    let tris = 100_000usize;
    let mut bin = Vec::new();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let index_offset = bin.len();
    for _ in 0..tris {
        bin.extend_from_slice(&[0u8, 1, 2]);
    }
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bin));
    let instances = 600;
    let mut nodes = vec![json!({"children": (1..=instances).collect::<Vec<_>>()})];
    nodes.extend((0..instances).map(|i| json!({"mesh": 0, "translation": [i as f64, 0.0, 0.0]})));
    let doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": index_offset, "byteLength": tris * 3}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5121, "count": tris * 3, "type": "SCALAR"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": nodes,
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    });
    let e = load_and_render(serde_json::to_vec(&doc).unwrap(), "instancing bomb".into()).unwrap_err();
    assert!(e.contains("triangles"), "{e}");
}

/// Regression: 30,000 coincident instances of a triangle (a 0.5 MB file) built the BVH in
/// quadratic time (over a minute).
#[test]
fn many_coincident_instances_load_and_render() {
    let n = 30_000;
    let mut nodes = vec![json!({"children": (1..=n).collect::<Vec<_>>()})];
    nodes.extend((0..n).map(|_| json!({"mesh": 0})));
    load_and_render(gltf_with_nodes(nodes, vec![0]), "coincident instances".into()).unwrap();
}
