//! Scene loading: fixtures written in code, the shared real-world samples, and every malformed
//! file of ../shared/gltf-invalid (a clear error, never a panic).

mod common;

use common::gltf_builder::{Gltf, quad};
use cubist::scene::{LightKind, Projection, Scene, World};
use cubist::{Error, Prepared};
use glam::{DVec3, Vec3};
use serde_json::json;

fn load(g: &Gltf) -> cubist::Result<Scene> {
    let dir = tempfile::tempdir().unwrap();
    let p = g.write(dir.path(), "t.gltf");
    Scene::load(&p)
}

fn tetra(g: &mut Gltf, with_normals: bool) -> usize {
    let p = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let pos = g.floats(&p, 3, true);
    let idx = g.indices(&[0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]);
    let mut attrs = json!({"POSITION": pos});
    if with_normals {
        let n = g.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 3, false);
        attrs["NORMAL"] = json!(n);
    }
    g.mesh(attrs, Some(idx), 4, None)
}

#[test]
fn indexed_and_non_indexed_triangles_strips_and_fans() {
    let mut g = Gltf::default();
    let pos = g.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 2.0, 1.0, 0.0], 3, true);
    let m_list = g.mesh(json!({"POSITION": pos}), None, 4, None); // 5 vertices -> 1 triangle
    let m_strip = g.mesh(json!({"POSITION": pos}), None, 5, None); // 3 triangles
    let m_fan = g.mesh(json!({"POSITION": pos}), None, 6, None); // 3 triangles
    let idx = g.indices(&[0, 1, 2, 2, 1, 3]);
    let m_idx = g.mesh(json!({"POSITION": pos}), Some(idx), 4, None); // 2 triangles
    for m in [m_list, m_strip, m_fan, m_idx] {
        let n = g.node(json!({"mesh": m}));
        g.scene_nodes.push(n);
    }
    let s = load(&g).unwrap();
    let counts: Vec<usize> = s.objects.iter().map(|o| s.meshes[o.mesh].triangles.len()).collect();
    assert_eq!(counts, vec![1, 3, 3, 2]);
    // Strip winding alternates so every triangle keeps the strip's orientation.
    let strip = &s.meshes[s.objects[1].mesh];
    assert_eq!(strip.triangles[1], [2, 1, 3]);
}

#[test]
fn points_and_lines_are_skipped_with_a_warning() {
    let mut g = Gltf::default();
    let pos = g.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3, true);
    let pts = g.mesh(json!({"POSITION": pos}), None, 0, None);
    let tri = g.mesh(json!({"POSITION": pos}), None, 4, None);
    for m in [pts, tri] {
        let n = g.node(json!({"mesh": m}));
        g.scene_nodes.push(n);
    }
    let s = load(&g).unwrap();
    assert_eq!(s.triangle_count(), 1);
    assert!(s.warnings.iter().any(|w| w.contains("Points")), "{:?}", s.warnings);

    // Only points: a clear empty-scene error.
    let mut g = Gltf::default();
    let pos = g.floats(&[0.0, 0.0, 0.0], 3, true);
    let m = g.mesh(json!({"POSITION": pos}), None, 0, None);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    assert!(matches!(load(&g), Err(Error::EmptyScene(_))));
}

#[test]
fn node_hierarchy_composes_world_transforms() {
    let mut g = Gltf::default();
    let m = tetra(&mut g, true);
    let child = g.node(json!({"mesh": m, "scale": [2.0, 2.0, 2.0], "translation": [1.0, 0.0, 0.0]}));
    let parent = g.node(
        json!({"children": [child], "translation": [0.0, 10.0, 0.0], "rotation": [0.0, 0.0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2]}),
    );
    g.scene_nodes.push(parent);
    let s = load(&g).unwrap();
    let t = s.objects[0].transform;
    // Local (1, 0, 0): child -> (3, 0, 0); parent rotates 90 deg about Z -> (0, 3, 0), then +10 y.
    let p = t.transform_point3(DVec3::X);
    assert!((p - DVec3::new(0.0, 13.0, 0.0)).length() < 1e-5, "{p:?}");
}

#[test]
fn missing_normals_are_computed_and_point_outwards() {
    let mut g = Gltf::default();
    let m = tetra(&mut g, false);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    let s = load(&g).unwrap();
    let mesh = &s.meshes[0];
    let centre = mesh.positions.iter().copied().sum::<Vec3>() / 4.0;
    for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
        assert!((n.length() - 1.0).abs() < 1e-5);
        assert!(n.dot(*p - centre) > 0.0, "normal {n:?} at {p:?} points inwards");
    }
}

#[test]
fn materials_textures_lights_and_camera_are_read() {
    let mut g = Gltf::default();
    // A 2x1 PNG: left red, right blue.
    let mut png = Vec::new();
    let img = image::RgbaImage::from_raw(2, 1, vec![255, 0, 0, 255, 0, 0, 255, 255]).unwrap();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    let tex = g.texture_png(&png);
    g.materials.push(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "baseColorTexture": {"index": tex}},
        "extensions": {"KHR_materials_unlit": {}}}),
    );
    g.extensions_used.push("KHR_materials_unlit".into());
    let m = quad(&mut g, Some(0));
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    g.lights.push(json!({"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 20.0}));
    let l = g.node(json!({"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0.0, 2.0, 3.0]}));
    g.scene_nodes.push(l);
    g.cameras.push(json!({"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100.0}}));
    let c = g.node(json!({"camera": 0, "translation": [0.0, 0.0, 4.0]}));
    g.scene_nodes.push(c);
    let s = load(&g).unwrap();

    assert!(s.materials[0].unlit);
    assert!(s.materials[0].base_color_texture.is_some());
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.lights[0].kind, LightKind::Point);
    assert!((s.lights[0].position - DVec3::new(0.0, 2.0, 3.0)).length() < 1e-6);
    let cam = s.camera.as_ref().unwrap();
    assert!((cam.position - DVec3::new(0.0, 0.0, 4.0)).length() < 1e-6);
    assert!((cam.forward - DVec3::NEG_Z).length() < 1e-6);
    assert!(matches!(cam.projection, Projection::Perspective { yfov } if (yfov - 0.8).abs() < 1e-6));

    // Rendered through the scene's own camera, the unlit texture shows exactly: red on the
    // left half of the quad, blue on the right (UV (0,0) is the image's top-left).
    let prep = Prepared::new(s);
    let settings = cubist::Settings {
        camera: cubist::settings::CameraKind::Perspective,
        width: 40,
        height: 40,
        spp: 1,
        ..cubist::Settings::preset(cubist::settings::Preset::Plain)
    };
    let r = cubist::render(&prep, &settings, &cubist::progress::Progress::silent()).unwrap();
    let px = |x: u32, y: u32| r.image.get_pixel(x, y).0;
    assert_eq!(px(15, 20), [255, 0, 0, 255]);
    assert_eq!(px(25, 20), [0, 0, 255, 255]);
}

#[test]
fn bad_data_gives_one_line_errors_naming_the_fault() {
    // NaN vertex.
    let mut g = Gltf::default();
    let pos = g.floats(&[0.0, 0.0, 0.0, f32::NAN, 0.0, 0.0, 0.0, 1.0, 0.0], 3, true);
    let m = g.mesh(json!({"POSITION": pos}), None, 4, None);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    let e = load(&g).unwrap_err().to_string();
    assert!(e.contains("POSITION") && e.contains("NaN"), "{e}");
    assert!(!e.contains('\n'));

    // Index out of range.
    let mut g = Gltf::default();
    let pos = g.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3, true);
    let idx = g.indices(&[0, 1, 7]);
    let m = g.mesh(json!({"POSITION": pos}), Some(idx), 4, None);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    let e = load(&g).unwrap_err().to_string();
    assert!(e.contains("index 7") && e.contains("out of range"), "{e}");

    // A required extension we cannot render.
    let mut g = Gltf::default();
    let m = tetra(&mut g, true);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    g.extensions_required.push("KHR_draco_mesh_compression".into());
    g.extensions_used.push("KHR_draco_mesh_compression".into());
    let e = load(&g).unwrap_err();
    assert!(matches!(e, Error::Unsupported { .. }), "{e}");
    assert!(e.to_string().contains("Draco"));

    // A missing external buffer names the file.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.gltf");
    std::fs::write(&p, r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"gone.bin"}]}"#).unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(e.contains("gone.bin"), "{e}");

    // Not a file at all.
    let e = Scene::load(std::path::Path::new("/nonexistent/scene.glb")).unwrap_err().to_string();
    assert!(e.contains("/nonexistent/scene.glb"), "{e}");
}

#[test]
fn node_loops_are_refused() {
    let mut g = Gltf::default();
    let m = tetra(&mut g, true);
    g.node(json!({"mesh": m, "children": [1]}));
    g.node(json!({"children": [0]}));
    g.scene_nodes.push(0);
    let e = load(&g).unwrap_err().to_string();
    assert!(e.contains("node"), "{e}");
}

#[test]
fn world_is_centred_and_unit_sized_whatever_the_scale_and_offset() {
    for (scale, offset) in [(1.0, 0.0), (1e-6, 0.0), (1e6, 0.0), (1.0, 1e6)] {
        let mut g = Gltf::default();
        let m = tetra(&mut g, true);
        let n = g.node(json!({"mesh": m, "scale": [scale, scale, scale], "translation": [offset, 0.0, 0.0]}));
        g.scene_nodes.push(n);
        let s = load(&g).unwrap();
        let w = World::new(&s);
        assert!((w.radius - 1.0).abs() < 1e-5, "scale {scale}: radius {}", w.radius);
        let centre = (w.bounds.0 + w.bounds.1) * 0.5;
        assert!(centre.length() < 1e-5, "scale {scale} offset {offset}: centre {centre:?}");
    }
}

/// Every real-world sample loads and renders (Draco is refused clearly; points/lines-only
/// files are empty scenes), and no pixel is NaN.
#[test]
#[ignore = "needs ../shared"]
fn shared_samples_load_and_render() {
    let dir = common::shared("gltf-samples");
    let mut files: Vec<_> = walk(&dir).into_iter().filter(|p| is_gltf(p)).collect();
    files.sort();
    assert!(files.len() > 30);
    for f in files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        match Prepared::load(Some(&f)) {
            Ok(prep) => {
                let s = cubist::Settings {
                    width: 48,
                    height: 36,
                    spp: 1,
                    ..cubist::Settings::preset(cubist::settings::Preset::Plain)
                };
                let r = cubist::render(&prep, &s, &cubist::progress::Progress::silent()).unwrap();
                assert!(r.film.color.iter().all(|c| c.is_finite()), "{name}: NaN pixel");
                assert!(r.film.hits.iter().any(|h| h.is_hit()), "{name}: nothing visible");
            }
            Err(Error::Unsupported { message, .. }) => assert!(name.contains("Draco"), "{name}: {message}"),
            Err(Error::EmptyScene(_)) => {
                let n: u32 =
                    name.trim_start_matches("Mesh_PrimitiveMode_").trim_end_matches(".glb").parse().unwrap_or(99);
                assert!(matches!(n, 0..=3 | 7..=10), "{name} should have triangles");
            }
            Err(e) => panic!("{name}: {e}"),
        }
    }
}

/// Every malformed file gives an error: never a panic, a hang or a scene.
#[test]
#[ignore = "needs ../shared"]
fn every_invalid_file_is_a_clear_error() {
    let dir = common::shared("gltf-invalid");
    let files: Vec<_> = walk(&dir).into_iter().filter(|p| is_gltf(p)).collect();
    assert!(files.len() >= 50);
    for f in files {
        match Scene::load(&f) {
            Ok(_) => panic!("{} loaded", f.display()),
            Err(e) => {
                let msg = e.to_string();
                assert!(!msg.contains('\n') && msg.len() < 400, "{}: {msg}", f.display());
            }
        }
    }
}

#[test]
fn in_memory_glb_and_gltf_load() {
    let mut g = Gltf::default();
    let m = tetra(&mut g, true);
    let q = common::gltf_builder::quad(&mut g, None);
    let n = g.node(json!({"mesh": m}));
    let k = g.node(json!({"mesh": q, "translation": [3.0, 0.0, 0.0]}));
    g.scene_nodes.extend([n, k]);
    assert_eq!(Scene::from_slice(&g.to_glb()).unwrap().triangle_count(), 6);
    assert_eq!(Scene::from_slice(g.to_json().as_bytes()).unwrap().triangle_count(), 6);
}

fn is_gltf(p: &std::path::Path) -> bool {
    matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb"))
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() { out.extend(walk(&p)) } else { out.push(p) }
    }
    out
}
