//! The framing's tests: the broad side, the near-C guard, objects on a floor.

use glam::DVec3;

use super::probe::{NEAR_C_RADII, NearGuard, PROBE_COLUMNS, probe_fill};
use super::*;
use crate::camera::Spherical;
use crate::pipeline::Prepared;
use crate::settings::Settings;

/// Corners of a box of `size` centred at `c`.
fn boxed(size: DVec3, c: DVec3) -> Vec<DVec3> {
    (0..8)
        .map(|i| c + 0.5 * size * DVec3::new([-1.0, 1.0][i & 1], [-1.0, 1.0][(i >> 1) & 1], [-1.0, 1.0][i >> 2]))
        .collect()
}

#[test]
fn the_broad_side_faces_the_widest_extent() {
    // A board seen edge-on (thin along X, long along Z): turned a quarter turn, either way
    // gives the same width, the first searched (-90 deg) is taken.
    let board = boxed(DVec3::new(0.05, 1.0, 1.6), DVec3::ZERO);
    let yaw = broad_side_yaw(&board, DVec3::NEG_Z, DVec3::Y).expect("a board seen edge-on turns");
    assert!((yaw.abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{yaw}");
    // Turned by 45 deg about Y, the board's broad side is found 45 deg from the front.
    let r = glam::DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
    let turned: Vec<DVec3> = board.iter().map(|p| r * *p).collect();
    let yaw = broad_side_yaw(&turned, DVec3::NEG_Z, DVec3::Y).expect("turns");
    assert!((yaw.abs() - std::f64::consts::FRAC_PI_4).abs() < 1e-9, "{yaw}");
    // Already broad from the front, or as wide from every side (a round column): no turn.
    assert_eq!(broad_side_yaw(&boxed(DVec3::new(1.6, 1.0, 0.05), DVec3::ZERO), DVec3::NEG_Z, DVec3::Y), None);
    let column: Vec<DVec3> = (0..72)
        .flat_map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 72.0;
            [DVec3::new(a.cos(), -1.5, a.sin()), DVec3::new(a.cos(), 1.5, a.sin())]
        })
        .collect();
    assert_eq!(broad_side_yaw(&column, DVec3::NEG_Z, DVec3::Y), None);
    // A square pillar is widest across its diagonal: turned 45 deg, two faces in view.
    let pillar = broad_side_yaw(&boxed(DVec3::new(1.0, 3.0, 1.0), DVec3::ZERO), DVec3::NEG_Z, DVec3::Y).expect("turns");
    assert!((pillar.abs() - std::f64::consts::FRAC_PI_4).abs() < 1e-9, "{pillar}");
    // The up axis decides what "horizontal" is: the same board modelled z-up.
    let zup: Vec<DVec3> = board.iter().map(|p| DVec3::new(p.x, -p.z, p.y)).collect();
    assert_eq!(
        broad_side_yaw(&zup, DVec3::NEG_Z, DVec3::Z),
        None,
        "seen from above (-Z is the up axis): no level front"
    );
    assert!(broad_side_yaw(&[], DVec3::NEG_Z, DVec3::Y).is_none());
}

fn params() -> FramingParams {
    crate::pipeline::params::framing(&Settings { width: 320, height: 240, ..Settings::default() })
}

/// The guard refuses a candidate whose fill is mostly one small part just in front of C: a
/// small ball right before a spherical camera's centre, a big one far beyond it.
#[test]
fn the_guard_refuses_a_part_magnified_near_c() {
    use crate::scene::default::ellipsoid;
    use crate::scene::{Material, Object, Scene};
    let mut s = Scene::default();
    s.materials.push(Material::default());
    for (r, z) in [(0.1f32, -0.5f64), (0.6, 1.5)] {
        s.meshes.push(ellipsoid("ball", glam::Vec3::splat(r), 12, 24, 0));
        s.objects.push(Object {
            name: "ball".into(),
            mesh: s.meshes.len() - 1,
            transform: glam::DMat4::from_translation(DVec3::new(0.0, 0.0, z)),
        });
    }
    let prep = Prepared::new(s);
    let sim = prep.world.to_render;
    // C just behind the small ball (render space), looking down -Z at both.
    let centre = sim.point_f64(DVec3::new(0.0, 0.0, -0.65));
    let (frame, _) = CameraFrame::new(centre + DVec3::Z * 4.0, DVec3::NEG_Z, DVec3::Y).unwrap();
    let cam = Spherical { frame, centre, distance: 4.0, angle_x: 2.0, angle_y: 1.5, clip_radius: 2.0 };
    let plain = probe_fill(&cam, &prep.accel, 4.0 / 3.0, PROBE_COLUMNS, None);
    assert!(plain > 0.3, "the small ball fills the probe: {plain}");
    let r = prep.world.radius as f64;
    let guard = |within: f64| NearGuard { centre, line: None, within };
    assert_eq!(probe_fill(&cam, &prep.accel, 4.0 / 3.0, PROBE_COLUMNS, Some(&guard(NEAR_C_RADII * r))), 0.0);
    // Nothing within a tiny distance of C: the same fill.
    assert_eq!(probe_fill(&cam, &prep.accel, 4.0 / 3.0, PROBE_COLUMNS, Some(&guard(1e-3))), plain);
}

/// Objects standing on a floor many times their size (`scene::backdrop`) are framed, not
/// the floor: the ball fills a good part of the canvas, as it does without the floor,
/// instead of a few pixels of a kite of floor; the floor is still in the picture.
#[test]
fn objects_on_a_floor_are_framed_without_it() {
    use crate::scene::default::{cuboid, ellipsoid};
    use crate::scene::{Material, Object, Scene};
    let share = |with_floor: bool| {
        let mut s = Scene::default();
        s.materials.push(Material::default());
        s.meshes.push(ellipsoid("ball", glam::Vec3::splat(1.0), 12, 24, 0));
        s.objects.push(Object { name: "ball".into(), mesh: 0, transform: glam::DMat4::from_translation(DVec3::Y) });
        if with_floor {
            s.meshes.push(cuboid("floor", glam::Vec3::new(40.0, 0.02, 40.0), 0));
            s.objects.push(Object {
                name: "floor".into(),
                mesh: 1,
                transform: glam::DMat4::from_translation(DVec3::new(0.0, -0.01, 0.0)),
            });
        }
        let prep = Prepared::new(s);
        let framed = frame_camera(&params(), &prep.world, &prep.accel).unwrap();
        let (w, h) = (64u32, 48u32);
        let (mut ball, mut floor) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let r = framed.camera.ray(crate::camera::screen_point(x, y, glam::DVec2::splat(0.5), w, h));
                match prep.accel.closest(r.origin, r.dir, 0.0, f32::INFINITY).map(|h| prep.world.object_of(h.tri)) {
                    Some(0) => ball += 1,
                    Some(_) => floor += 1,
                    None => {}
                }
            }
        }
        (ball as f64 / (w * h) as f64, floor as f64 / (w * h) as f64)
    };
    let (alone, _) = share(false);
    let (ball, floor) = share(true);
    assert!(alone > 0.4, "{alone}");
    assert!(ball > 0.5 * alone, "the ball on the floor {ball:.3}, alone {alone:.3}");
    assert!(floor > 0.05, "the floor is in the picture: {floor:.3}");
}
