//! glTF animation: the InterpolationTest sample's channels against values computed by hand
//! from its keyframes, the animated samples' poses, and malformed animations (a clear reason,
//! the scene still loading).

mod common;

use common::gltf_builder::{Gltf, quad};
use cubist::scene::Scene;
use cubist::scene::animation::{self, Choice, Clip};
use glam::{DMat4, DQuat, DVec3};
use serde_json::json;

fn sample(name: &str) -> Scene {
    Scene::load(&common::shared(&format!("gltf-samples/{name}"))).unwrap()
}

/// The world transform of the object named `node` at `time` under `clip`.
fn transform_at(scene: &Scene, clip: &str, node: &str, time: f64) -> DMat4 {
    let clips = animation::select(scene, &Choice::Name(clip.into())).unwrap();
    let rig = scene.rig.as_ref().unwrap();
    let pose = rig.pose(&clips, time, |m| &scene.meshes[m].triangles);
    let o = scene.objects.iter().position(|o| o.name == node).unwrap_or_else(|| panic!("no object {node}"));
    pose.transforms.iter().find(|(i, _)| *i == o).map(|(_, m)| *m).unwrap_or(scene.objects[o].transform)
}

fn trs(m: DMat4) -> (DVec3, DQuat, DVec3) {
    let (s, r, t) = m.to_scale_rotation_translation();
    (t, r, s)
}

fn z_angle_deg(q: DQuat) -> f64 {
    // In (-180, 180]: q and -q (a matrix does not tell them apart) are the same rotation.
    let (axis, angle) = q.to_axis_angle();
    let a = (angle * axis.z.signum()).to_degrees();
    a - 360.0 * ((a + 180.0) / 360.0).floor()
}

#[test]
#[ignore = "needs ../shared"]
fn interpolation_test_matches_hand_computed_values() {
    let s = sample("InterpolationTest.glb");
    let names: Vec<String> = s.rig.as_ref().unwrap().clips.iter().map(|c| c.as_ref().unwrap().name.clone()).collect();
    assert_eq!(names.len(), 9, "{names:?}");
    // Scale keys 1, 0.5, 1, 0.5, 1 at t = 0.0417, 0.4167, 0.875, 1.25, 1.6667.
    let scale = |clip, node, t| trs(transform_at(&s, clip, node, t)).2.x;
    let mid = (0.4166666666 + 0.875) / 2.0;
    assert!((scale("Step Scale", "Cube", mid) - 0.5).abs() < 1e-6, "STEP holds the previous key");
    assert!((scale("Step Scale", "Cube", 0.0) - 1.0).abs() < 1e-6, "clamped before the first key");
    assert!((scale("Linear Scale", "Cube.001", mid) - 0.75).abs() < 1e-6);
    // Cubic spline with zero tangents from 0.5 to 1: at u = 1/4 the Hermite weight of the end
    // is 3u^2 - 2u^3 = 0.15625, so 0.5 + 0.5 * 0.15625.
    let quarter = 0.4166666666 + 0.25 * (0.875 - 0.4166666666);
    assert!((scale("CubicSpline Scale", "Cube.002", quarter) - 0.578125).abs() < 1e-5);
    assert!((scale("CubicSpline Scale", "Cube.002", 1.25) - 0.5).abs() < 1e-6, "a key gives its vertex");

    // Rotations about -Z: 0, 45, 90, 135, 180 deg at t = 0, 0.4167, 0.875, 1.25, 1.7083.
    let angle = |clip, node, t| z_angle_deg(trs(transform_at(&s, clip, node, t)).1);
    let a = angle("Step Rotation", "Cube.003", 1.0);
    assert!((a + 90.0).abs() < 1e-4, "{a}");
    assert!((angle("Linear Rotation", "Cube.005", mid) + 67.5).abs() < 1e-4, "slerp halfway from 45 to 90 deg");
    let q = trs(transform_at(&s, "CubicSpline Rotation", "Cube.004", mid)).1;
    assert!((q.length() - 1.0).abs() < 1e-9, "normalised");
    assert!((angle("CubicSpline Rotation", "Cube.004", 0.875) + 90.0).abs() < 1e-4);
    let a = angle("CubicSpline Rotation", "Cube.004", mid);
    assert!(a < -45.0 && a > -90.0, "{a}");
    // The last key is 180 deg: -q and q meet, the path stays the short one.
    let late = angle("Linear Rotation", "Cube.005", 1.5);
    assert!(late < -135.0 && late > -180.0 || late > 179.0, "{late}");

    // Translations along Y.
    let y = |clip, node, t| trs(transform_at(&s, clip, node, t)).0.y;
    assert!((y("Step Translation", "Cube.006", 0.3) - 6.6652).abs() < 1e-3);
    assert!((y("Step Translation", "Cube.006", 0.5) - 10.0).abs() < 1e-5);
    // Linear halfway between y = 6.621 and y = 10.
    assert!((y("Linear Translation", "Cube.009", 0.2083333333) - (6.62098 + 10.0) / 2.0).abs() < 1e-3);
    // Cubic with zero tangents halfway between 10 and 6: 8.
    assert!((y("CubicSpline Translation", "Cube.008", (0.4166666666 + 0.8333333333) / 2.0) - 8.0).abs() < 1e-4);
}

#[test]
#[ignore = "needs ../shared"]
fn animated_samples_move_and_rest_where_their_clips_say() {
    for (file, clip, moved_meshes) in [
        ("CesiumMan.glb", Choice::Index(0), true),
        ("Fox.glb", Choice::Name("Walk".into()), true),
        ("AnimatedMorphCube.glb", Choice::Index(0), true),
        ("CesiumMilkTruck.glb", Choice::Index(0), false),
    ] {
        let s = sample(file);
        let clips = animation::select(&s, &clip).unwrap();
        let rig = s.rig.as_ref().unwrap();
        let end = clips.iter().map(|c: &&Clip| c.end()).fold(0.0, f64::max);
        assert!(end > 0.0, "{file}");
        let a = rig.pose(&clips, 0.0, |m| &s.meshes[m].triangles);
        let b = rig.pose(&clips, end * 0.37, |m| &s.meshes[m].triangles);
        if moved_meshes {
            assert!(!b.meshes.is_empty(), "{file}: deformed meshes");
            assert_ne!(a.meshes, b.meshes, "{file}: vertices move");
            for (m, p, n) in &b.meshes {
                assert_eq!(p.len(), s.meshes[*m].positions.len());
                assert!(p.iter().all(|p| p.is_finite()) && n.iter().all(|n| (n.length() - 1.0).abs() < 1e-3));
            }
        } else {
            assert_ne!(a.transforms, b.transforms, "{file}: the wheels turn");
        }
    }
}

/// A quad on node 0 animated by one channel; `build` adds the sampler's accessors and returns
/// (sampler, channel target).
fn animated_quad(build: impl FnOnce(&mut Gltf) -> (serde_json::Value, serde_json::Value)) -> Gltf {
    let mut g = Gltf::default();
    let m = quad(&mut g, None);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    let (sampler, target) = build(&mut g);
    g.animations.push(json!({"name": "a", "samplers": [sampler], "channels": [{"sampler": 0, "target": target}]}));
    g
}

fn load(g: &Gltf) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    Scene::load(&g.write(dir.path(), "a.gltf")).expect("a bad animation must not stop the scene from loading")
}

fn clip_error(s: &Scene) -> String {
    s.rig.as_ref().unwrap().clips[0].clone().unwrap_err()
}

#[test]
fn malformed_animations_are_kept_as_their_reason() {
    // Times going backwards.
    let g = animated_quad(|g| {
        let (i, o) = (g.scalars(&[0.0, 2.0, 1.0]), g.values(&[0.0; 9], 3));
        (json!({"input": i, "output": o}), json!({"node": 0, "path": "translation"}))
    });
    let s = load(&g);
    assert!(clip_error(&s).contains("strictly increasing"), "{}", clip_error(&s));
    let e = animation::select(&s, &Choice::Index(0)).unwrap_err().to_string();
    assert!(e.contains("animation 0") && e.contains("strictly increasing"), "{e}");

    // Too few outputs for a cubic spline.
    let g = animated_quad(|g| {
        let (i, o) = (g.scalars(&[0.0, 1.0]), g.values(&[1.0; 6], 3));
        (json!({"input": i, "output": o, "interpolation": "CUBICSPLINE"}), json!({"node": 0, "path": "scale"}))
    });
    assert!(clip_error(&load(&g)).contains("2 output elements for 2 keyframes"), "{}", clip_error(&load(&g)));

    // Morph weights on a node without morph targets.
    let g = animated_quad(|g| {
        let (i, o) = (g.scalars(&[0.0, 1.0]), g.scalars(&[0.0, 1.0]));
        (json!({"input": i, "output": o}), json!({"node": 0, "path": "weights"}))
    });
    assert!(clip_error(&load(&g)).contains("no morph targets"));

    // A channel on a node placed by a matrix.
    let g = animated_quad(|g| {
        g.nodes[0]["matrix"] = json!([1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let (i, o) = (g.scalars(&[0.0, 1.0]), g.values(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], 4));
        (json!({"input": i, "output": o}), json!({"node": 0, "path": "rotation"}))
    });
    assert!(clip_error(&load(&g)).contains("matrix"));
}

#[test]
fn a_valid_animation_moves_the_quad_and_rests_at_its_first_key() {
    let g = animated_quad(|g| {
        let (i, o) = (g.scalars(&[0.0, 1.0]), g.values(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.0], 3));
        (json!({"input": i, "output": o}), json!({"node": 0, "path": "translation"}))
    });
    let s = load(&g);
    assert!(s.warnings.iter().all(|w| !w.contains("animation")), "{:?}", s.warnings);
    let clips = animation::select(&s, &Choice::All).unwrap();
    let pose = s.rig.as_ref().unwrap().pose(&clips, 0.25, |m| &s.meshes[m].triangles);
    assert_eq!(pose.transforms, vec![(0, DMat4::from_translation(DVec3::new(0.5, 0.0, 0.0)))]);
}
