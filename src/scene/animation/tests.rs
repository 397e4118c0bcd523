//! Poses of hand-built rigs against values computed by hand.

use std::f64::consts::FRAC_PI_2;
use std::sync::Arc;

use glam::{DMat4, DQuat, DVec3, Vec3};

use super::*;
use crate::scene::{Mesh, Object, Scene};

fn trs(t: DVec3) -> Local {
    Local::Trs { translation: t, rotation: DQuat::IDENTITY, scale: DVec3::ONE }
}

fn node(parent: Option<u32>, local: Local) -> RigNode {
    RigNode { parent, local, weights: Vec::new() }
}

fn linear(times: &[f32], values: &[f32], width: usize) -> Arc<Sampler> {
    Arc::new(Sampler::new(times.to_vec(), values.to_vec(), width, Interpolation::Linear).unwrap())
}

fn clip(channels: Vec<Channel>, samplers: Vec<Arc<Sampler>>) -> Clip {
    Clip { name: "test".into(), channels, samplers }
}

const NO_TRIANGLES: &[[u32; 3]] = &[];

/// Node 0 turns about Y from 0 to 90 degrees over one second; node 1, its child, sits one unit
/// along +X and carries object 0. At t = 0.5 (45 degrees, slerp) the object's origin is at
/// (cos 45, 0, -sin 45).
#[test]
fn a_child_follows_its_rotating_parent() {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let rig = Rig {
        nodes: vec![node(None, trs(DVec3::ZERO)), node(Some(0), trs(DVec3::X))],
        order: vec![0, 1],
        instances: vec![Instance { node: 1, mesh: 0, skin: None, deform: None }],
        ..Rig::default()
    };
    let c = clip(
        vec![Channel { node: 0, property: Property::Rotation, sampler: 0 }],
        vec![linear(&[0.0, 1.0], &[0.0, 0.0, 0.0, 1.0, 0.0, h, 0.0, h], 4)],
    );
    let pose = rig.pose(&[&c], 0.5, |_| NO_TRIANGLES);
    assert_eq!(pose.transforms.len(), 1);
    let (o, m) = pose.transforms[0];
    assert_eq!(o, 0);
    let p = m.transform_point3(DVec3::ZERO);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    assert!((p - DVec3::new(s, 0.0, -s)).length() < 1e-7, "{p:?}");
    // At the end and beyond: 90 degrees, (0, 0, -1).
    for t in [1.0, 5.0] {
        let p = rig.pose(&[&c], t, |_| NO_TRIANGLES).transforms[0].1.transform_point3(DVec3::ZERO);
        assert!((p - DVec3::NEG_Z).length() < 1e-7, "{p:?}");
    }
    assert!(c.end() == 1.0);
}

/// One morph target lifting three vertices by 2 along Y, its weight going linearly 0 -> 1 over
/// two seconds: at t = 0.5 the weight is 0.25 and every vertex rises by 0.5.
#[test]
fn morph_weights_move_vertices() {
    let base = vec![Vec3::ZERO, Vec3::X, Vec3::Z];
    let d = Deformable {
        positions: base.clone(),
        normals: None,
        targets: vec![MorphTarget { positions: Some(vec![Vec3::new(0.0, 2.0, 0.0); 3]), normals: None }],
        skinning: None,
    };
    let rig = Rig {
        nodes: vec![RigNode { parent: None, local: trs(DVec3::ZERO), weights: vec![0.0] }],
        order: vec![0],
        instances: vec![Instance { node: 0, mesh: 0, skin: None, deform: Some(Arc::new(d)) }],
        ..Rig::default()
    };
    let c = clip(
        vec![Channel { node: 0, property: Property::Weights, sampler: 0 }],
        vec![linear(&[0.0, 2.0], &[0.0, 1.0], 1)],
    );
    let tris: &[[u32; 3]] = &[[0, 1, 2]];
    let pose = rig.pose(&[&c], 0.5, |_| tris);
    assert!(pose.transforms.is_empty(), "weights move no node");
    let (mesh, p, n) = &pose.meshes[0];
    assert_eq!(*mesh, 0);
    for (p, b) in p.iter().zip(&base) {
        assert!((*p - (*b + Vec3::new(0.0, 0.5, 0.0))).length() < 1e-6, "{p:?}");
    }
    // No normals in the file: the triangle's, facing -Y... (X x Z = -Y).
    assert!((n[0] - Vec3::NEG_Y).length() < 1e-6, "{n:?}");
}

/// Two joints: the root (node 0) and node 1 moving from x = 0 to x = 4 over one second. A
/// vertex weighted half to each moves half as far: 1 unit at t = 0.5. The skinned object's own
/// transform stays the identity.
#[test]
fn skinned_vertices_blend_their_joints() {
    let d = Deformable {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: Some(vec![Vec3::Z; 3]),
        targets: Vec::new(),
        skinning: Some(Skinning {
            joints: vec![[0, 1, 0, 0], [0, 0, 0, 0], [1, 0, 0, 0]],
            weights: vec![[0.5, 0.5, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0]],
        }),
    };
    let rig = Rig {
        nodes: vec![node(None, trs(DVec3::ZERO)), node(Some(0), trs(DVec3::ZERO)), node(None, trs(DVec3::ZERO))],
        order: vec![0, 1, 2],
        instances: vec![Instance { node: 2, mesh: 0, skin: Some(0), deform: Some(Arc::new(d)) }],
        skins: vec![Skin { joints: vec![0, 1], inverse_bind: vec![DMat4::IDENTITY; 2] }],
        ..Rig::default()
    };
    let c = clip(
        vec![Channel { node: 1, property: Property::Translation, sampler: 0 }],
        vec![linear(&[0.0, 1.0], &[0.0, 0.0, 0.0, 4.0, 0.0, 0.0], 3)],
    );
    let tris: &[[u32; 3]] = &[[0, 1, 2]];
    let pose = rig.pose(&[&c], 0.5, |_| tris);
    assert!(pose.transforms.is_empty(), "a skinned object is placed by its joints only");
    let (_, p, n) = &pose.meshes[0];
    assert!((p[0] - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6, "{p:?}");
    assert_eq!(p[1], Vec3::X, "all weight on the still root");
    // Weights that do not sum to 1 are renormalised: fully on joint 1, moved by 2.
    assert!((p[2] - Vec3::new(2.0, 1.0, 0.0)).length() < 1e-6, "{p:?}");
    assert!(n.iter().all(|n| (*n - Vec3::Z).length() < 1e-6), "translations keep normals");
}

#[test]
fn a_pose_at_rest_leaves_the_deformed_mesh_as_loaded() {
    // The loader's rest pose is `deform` at the rest weights: sampling a clip whose value is
    // the rest value gives the same numbers, bit for bit.
    let d = Deformable {
        positions: vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.7, -0.2, 0.0), Vec3::new(0.0, 1.3, 0.9)],
        normals: Some(vec![Vec3::new(0.0, 0.6, 0.8); 3]),
        targets: vec![MorphTarget {
            positions: Some(vec![Vec3::new(0.3, 0.1, -0.7); 3]),
            normals: Some(vec![Vec3::new(0.1, 0.0, 0.0); 3]),
        }],
        skinning: None,
    };
    let tris = [[0u32, 1, 2]];
    let rest = deform(&d, &[0.3], None, &tris);
    let rig = Rig {
        nodes: vec![RigNode { parent: None, local: trs(DVec3::ZERO), weights: vec![0.3] }],
        order: vec![0],
        instances: vec![Instance { node: 0, mesh: 0, skin: None, deform: Some(Arc::new(d)) }],
        ..Rig::default()
    };
    let c = clip(
        vec![Channel { node: 0, property: Property::Weights, sampler: 0 }],
        vec![linear(&[0.0, 1.0], &[0.3, 0.9], 1)],
    );
    let pose = rig.pose(&[&c], 0.0, |_| &tris);
    assert_eq!((pose.meshes[0].1.clone(), pose.meshes[0].2.clone()), rest);
}

#[test]
fn apply_puts_a_pose_into_a_scene() {
    let mesh = Mesh {
        name: "m".into(),
        positions: vec![Vec3::ZERO; 3],
        normals: vec![Vec3::Y; 3],
        uvs: None,
        colors: None,
        triangles: vec![[0, 1, 2]],
        material: None,
    };
    let mut scene = Scene {
        meshes: vec![mesh],
        objects: vec![Object { name: "o".into(), mesh: 0, transform: DMat4::IDENTITY }],
        ..Scene::default()
    };
    let pose = Pose {
        transforms: vec![(0, DMat4::from_translation(DVec3::X))],
        meshes: vec![(0, vec![Vec3::X; 3], vec![Vec3::Z; 3])],
        camera: None,
        lights: Vec::new(),
    };
    apply(&mut scene, &pose);
    assert_eq!(scene.objects[0].transform, DMat4::from_translation(DVec3::X));
    assert_eq!(scene.meshes[0].positions, vec![Vec3::X; 3]);
    assert_eq!(scene.meshes[0].normals, vec![Vec3::Z; 3]);
}

#[test]
fn animated_cameras_keep_an_orthonormal_frame() {
    let m = DMat4::from_rotation_translation(DQuat::from_rotation_y(FRAC_PI_2), DVec3::new(1.0, 2.0, 3.0));
    let c = camera_at(m, crate::scene::Projection::Perspective { yfov: 1.0 }).unwrap();
    assert!((c.position - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
    assert!((c.forward - DVec3::NEG_X).length() < 1e-12, "{:?}", c.forward);
    assert!((c.up - DVec3::Y).length() < 1e-12);
    assert!(camera_at(DMat4::ZERO, crate::scene::Projection::Perspective { yfov: 1.0 }).is_none());
}

#[test]
fn choices_parse_and_name_what_the_scene_offers() {
    assert_eq!(Choice::parse("all"), Choice::All);
    assert_eq!(Choice::parse("2"), Choice::Index(2));
    assert_eq!(Choice::parse("Walk"), Choice::Name("Walk".into()));
    let c = clip(vec![Channel { node: 0, property: Property::Scale, sampler: 0 }], vec![linear(&[0.0], &[1.0; 3], 3)]);
    let walk = Clip { name: "Walk".into(), ..c.clone() };
    let rig = Rig { clips: vec![Ok(c), Ok(walk), Err("channel 0: bad".into())], ..Rig::default() };
    let scene = Scene { rig: Some(Arc::new(rig)), source: "s.glb".into(), ..Scene::default() };
    assert_eq!(select(&scene, &Choice::Name("Walk".into())).unwrap()[0].name, "Walk");
    assert_eq!(select(&scene, &Choice::Index(0)).unwrap()[0].name, "test");
    let e = select(&scene, &Choice::Name("Run".into())).unwrap_err().to_string();
    assert!(e.contains("no animation named `Run`") && e.contains("1: Walk") && e.contains("2: (invalid)"), "{e}");
    let e = select(&scene, &Choice::Index(2)).unwrap_err().to_string();
    assert!(e.contains("animation 2: channel 0: bad"), "{e}");
    assert!(select(&scene, &Choice::All).is_err(), "one clip cannot be played");
    let e = select(&Scene::default(), &Choice::All).unwrap_err().to_string();
    assert!(e.contains("has no animation"), "{e}");
}

#[test]
fn the_default_plays_the_first_animation_and_those_of_other_nodes() {
    let on = |name: &str, nodes: &[u32]| Clip {
        name: name.into(),
        channels: nodes.iter().map(|&node| Channel { node, property: Property::Translation, sampler: 0 }).collect(),
        samplers: vec![linear(&[0.0], &[0.0; 3], 3)],
    };
    let names = |clips: Vec<std::result::Result<Clip, String>>| {
        let rig = Rig { clips, ..Rig::default() };
        let scene = Scene { rig: Some(Arc::new(rig)), source: "s.glb".into(), ..Scene::default() };
        select(&scene, &Choice::Default).map(|c| c.iter().map(|c| c.name.clone()).collect::<Vec<_>>())
    };
    // Blender's export, one animation per object: the figure's and the camera's both play.
    assert_eq!(names(vec![Ok(on("figure", &[0, 1])), Ok(on("camera", &[5]))]).unwrap(), ["figure", "camera"]);
    // Alternatives for one rig (Fox's Survey, Walk, Run): the first; a later one sharing a
    // node with any chosen one is left out, one of other nodes joins.
    let fox = vec![Ok(on("Survey", &[0, 1])), Ok(on("Walk", &[1, 2])), Ok(on("cam", &[7])), Ok(on("Run", &[7, 8]))];
    assert_eq!(names(fox).unwrap(), ["Survey", "cam"]);
    // A later animation that does not load is left out; a first one that does not is an error.
    assert_eq!(names(vec![Ok(on("a", &[0])), Err("bad".into()), Ok(on("b", &[1]))]).unwrap(), ["a", "b"]);
    let e = names(vec![Err("channel 0: bad".into()), Ok(on("b", &[1]))]).unwrap_err().to_string();
    assert!(e.contains("animation 0: channel 0: bad"), "{e}");
}
