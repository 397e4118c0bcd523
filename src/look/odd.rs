//! Odd scenes the shared models do not cover (our scenes are not the users'):
//! very tall, very flat, z-up, several objects spread out, a figure walking across the view,
//! a pole, a board seen edge-on, a long bench, far from the origin, huge and tiny, objects on a
//! floor many times their size, a room modelled as one closed box around the camera. Built in code so the look report and the tests check the composition and the planes
//! on them without any file (`cubist look --odd`).

use glam::{DMat4, DQuat, DVec3, Vec2, Vec3, Vec4};

use crate::scene::default::{cuboid, ellipsoid, lathe};
use crate::scene::{Material, Mesh, Object, Projection, Scene, SceneCamera};

fn material(name: &str, r: f32, g: f32, b: f32) -> Material {
    Material { name: name.into(), base_color: Vec4::new(r, g, b, 1.0), roughness: 0.5, ..Material::default() }
}

/// A standing figure about +Y, `height` tall: a lathe body (legs, waist, chest, shoulders)
/// and an ellipsoid head, so saliency has a face-sized feature to find.
fn figure(height: f32) -> Vec<(Mesh, DMat4)> {
    let v = |r: f32, y: f32| Vec2::new(r * height, y * height);
    let body = [
        v(0.0, 0.0),
        v(0.06, 0.0),
        v(0.05, 0.25),
        v(0.07, 0.48),
        v(0.06, 0.55),
        v(0.09, 0.7),
        v(0.1, 0.78),
        v(0.04, 0.82),
        v(0.0, 0.83),
    ];
    let head = ellipsoid("head", Vec3::new(0.05, 0.07, 0.055) * height, 16, 24, 0);
    vec![
        (lathe("body", &body, 32, 0), DMat4::IDENTITY),
        (head, DMat4::from_translation(DVec3::new(0.0, 0.9 * height as f64, 0.0))),
    ]
}

/// A figure walking along +X (seen from its side by the default view), `height` tall:
/// ellipsoid head, torso, legs apart in a stride, one arm reaching forward and one swinging
/// back; thin from the front, its outline fills little of its bounding box from the side.
fn walker(height: f64) -> Vec<(Mesh, DMat4)> {
    let e = |name: &str, r: [f64; 3]| ellipsoid(name, (DVec3::from(r) * height).as_vec3(), 12, 20, 0);
    let at = |x: f64, y: f64, z: f64| DMat4::from_translation(DVec3::new(x, y, z) * height);
    let tilt = |a: f64| DMat4::from_rotation_z(a);
    vec![
        (e("head", [0.055, 0.065, 0.05]), at(0.01, 0.91, 0.0)),
        (e("torso", [0.07, 0.17, 0.11]), at(0.0, 0.66, 0.0)),
        (e("leg", [0.04, 0.25, 0.04]), at(0.09, 0.25, 0.05) * tilt(0.35)),
        (e("leg", [0.04, 0.25, 0.04]), at(-0.09, 0.25, -0.05) * tilt(-0.35)),
        (e("arm", [0.2, 0.03, 0.03]), at(0.2, 0.76, 0.13)),
        (e("arm", [0.03, 0.18, 0.03]), at(-0.06, 0.6, -0.13) * tilt(-0.4)),
    ]
}

/// Adds `parts` to `s`, each placed by `transform` after its own.
fn add(s: &mut Scene, parts: Vec<(Mesh, DMat4)>, transform: DMat4) {
    for (mesh, local) in parts {
        let name = mesh.name.clone();
        s.meshes.push(mesh);
        s.objects.push(Object { name, mesh: s.meshes.len() - 1, transform: transform * local });
    }
}

fn scene(name: &str) -> Scene {
    let mut s = Scene { source: format!("<odd: {name}>").into(), ..Scene::default() };
    s.materials.push(material("clay", 0.7, 0.6, 0.5));
    s
}

/// The odd scenes, each with its name.
pub fn odd_scenes() -> Vec<(String, Scene)> {
    let mut out = Vec::new();
    // A very tall, thin figure (height 12 x its width).
    let mut s = scene("tall");
    add(&mut s, figure(2.0), DMat4::IDENTITY);
    out.push(("odd-tall".to_string(), s));
    // A very flat plate seen face on, with a knob on it.
    let mut s = scene("flat");
    add(&mut s, vec![(ellipsoid("plate", Vec3::new(1.0, 0.6, 0.03), 24, 48, 0), DMat4::IDENTITY)], DMat4::IDENTITY);
    add(
        &mut s,
        vec![(ellipsoid("knob", Vec3::splat(0.12), 12, 24, 0), DMat4::from_translation(DVec3::new(0.3, 0.1, 0.08)))],
        DMat4::IDENTITY,
    );
    out.push(("odd-flat".to_string(), s));
    // A figure modelled z-up (lying along the view axis for a y-up camera).
    let mut s = scene("z-up");
    add(&mut s, figure(1.0), DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2));
    out.push(("odd-z-up".to_string(), s));
    // Several objects spread along a line, as on a shelf.
    let mut s = scene("several");
    for k in 0..5 {
        let x = (k as f64 - 2.0) * 0.9;
        let part = match k % 3 {
            0 => (cuboid("box", Vec3::new(0.4, 0.5, 0.4), 0), DMat4::IDENTITY),
            1 => (ellipsoid("ball", Vec3::splat(0.25), 16, 24, 0), DMat4::IDENTITY),
            _ => (ellipsoid("egg", Vec3::new(0.18, 0.3, 0.18), 16, 24, 0), DMat4::IDENTITY),
        };
        add(&mut s, vec![part], DMat4::from_translation(DVec3::new(x, 0.0, 0.2 * (k % 2) as f64)));
    }
    out.push(("odd-several".to_string(), s));
    // Tall, thin and wide subjects seen from an awkward side (fill on tall and thin
    // subjects, checked on shapes other than the shared models'): a figure walking across the
    // view, an arm reaching out; a pole ten times taller than wide with a knob; a board seen
    // edge-on (its broad side faces +X); a long low bench.
    let mut s = scene("walker");
    add(&mut s, walker(1.8), DMat4::IDENTITY);
    out.push(("odd-walker".to_string(), s));
    let mut s = scene("pole");
    let pole = [Vec2::new(0.0, 0.0), Vec2::new(0.1, 0.0), Vec2::new(0.08, 2.0), Vec2::new(0.0, 2.0)];
    add(&mut s, vec![(lathe("pole", &pole, 24, 0), DMat4::IDENTITY)], DMat4::IDENTITY);
    add(
        &mut s,
        vec![(ellipsoid("knob", Vec3::splat(0.12), 12, 24, 0), DMat4::from_translation(DVec3::new(0.0, 2.05, 0.0)))],
        DMat4::IDENTITY,
    );
    out.push(("odd-pole".to_string(), s));
    let mut s = scene("board");
    add(&mut s, vec![(cuboid("board", Vec3::new(0.06, 0.9, 1.6), 0), DMat4::IDENTITY)], DMat4::IDENTITY);
    add(
        &mut s,
        vec![(
            ellipsoid("boss", Vec3::new(0.08, 0.2, 0.2), 12, 24, 0),
            DMat4::from_translation(DVec3::new(0.05, 0.1, 0.3)),
        )],
        DMat4::IDENTITY,
    );
    out.push(("odd-board".to_string(), s));
    let mut s = scene("bench");
    add(
        &mut s,
        vec![(cuboid("seat", Vec3::new(2.4, 0.08, 0.4), 0), DMat4::from_translation(DVec3::new(0.0, 0.4, 0.0)))],
        DMat4::IDENTITY,
    );
    for x in [-1.05, 1.05] {
        add(
            &mut s,
            vec![(cuboid("leg", Vec3::new(0.1, 0.4, 0.35), 0), DMat4::from_translation(DVec3::new(x, 0.2, 0.0)))],
            DMat4::IDENTITY,
        );
    }
    out.push(("odd-bench".to_string(), s));
    // The figure far from the origin, huge and tiny.
    for (name, t) in [
        ("odd-far", DMat4::from_translation(DVec3::new(1.0e6, -2.0e5, 3.0e5))),
        ("odd-huge", DMat4::from_scale(DVec3::splat(1.0e4))),
        (
            "odd-tiny",
            DMat4::from_scale_rotation_translation(DVec3::splat(1.0e-4), DQuat::from_rotation_y(0.6), DVec3::ZERO),
        ),
    ] {
        let mut s = scene(name);
        add(&mut s, figure(1.0), t);
        add(
            &mut s,
            vec![(
                cuboid("pedestal", Vec3::new(0.4, 0.2, 0.4), 0),
                DMat4::from_translation(DVec3::new(0.0, -0.1, 0.0)),
            )],
            t,
        );
        out.push((name.to_string(), s));
    }
    // A jug and a ball standing on a floor thirty times their size (`scene::backdrop`), as
    // most scenes made in Blender stand on one.
    let mut s = scene("floor");
    let v = |r: f32, y: f32| Vec2::new(r, y);
    let jug = [v(0.0, 0.0), v(0.3, 0.0), v(0.4, 0.3), v(0.35, 0.6), v(0.15, 0.8), v(0.18, 1.0), v(0.0, 1.0)];
    add(&mut s, vec![(lathe("jug", &jug, 32, 0), DMat4::IDENTITY)], DMat4::IDENTITY);
    add(
        &mut s,
        vec![(ellipsoid("ball", Vec3::splat(0.3), 16, 24, 0), DMat4::from_translation(DVec3::new(0.7, 0.3, 0.3)))],
        DMat4::IDENTITY,
    );
    add(
        &mut s,
        vec![(cuboid("floor", Vec3::new(30.0, 0.02, 30.0), 0), DMat4::from_translation(DVec3::new(0.0, -0.01, 0.0)))],
        DMat4::IDENTITY,
    );
    out.push(("odd-floor".to_string(), s));
    // A room modelled as one closed box with the camera inside it (`scene::enclosure`), as
    // Blender users build interiors: a jug, a ball and a crate on its floor.
    let mut s = scene("room");
    add(
        &mut s,
        vec![(cuboid("room", Vec3::new(8.0, 4.0, 8.0), 0), DMat4::from_translation(DVec3::new(0.0, 2.0, 0.0)))],
        DMat4::IDENTITY,
    );
    let inside = DMat4::from_translation(DVec3::new(0.0, 0.0, -1.5));
    add(&mut s, vec![(lathe("jug", &jug, 32, 0), DMat4::IDENTITY)], inside);
    add(
        &mut s,
        vec![(ellipsoid("ball", Vec3::splat(0.3), 16, 24, 0), DMat4::from_translation(DVec3::new(0.8, 0.3, 0.4)))],
        inside,
    );
    add(
        &mut s,
        vec![(cuboid("crate", Vec3::new(0.7, 0.6, 0.6), 0), DMat4::from_translation(DVec3::new(-0.9, 0.3, -0.3)))],
        inside,
    );
    s.camera = Some(SceneCamera {
        position: DVec3::new(0.3, 1.5, 2.5),
        forward: DVec3::new(-0.1, -0.35, -1.0).normalize(),
        up: DVec3::Y,
        projection: Projection::Perspective { yfov: 0.8 },
        focus_distance: None,
    });
    out.push(("odd-room".to_string(), s));
    out
}
