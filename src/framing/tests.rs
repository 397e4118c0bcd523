//! The framing's tests: the broad side, the near-C guard, objects on a floor, an open room.

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
/// The object each pixel of a 64 x 48 picture through `framed` shows (None: nothing).
fn objects_seen<'a>(framed: &'a Framed, prep: &'a Prepared) -> impl Iterator<Item = Option<u32>> + 'a {
    let (w, h) = (64u32, 48u32);
    (0..h).flat_map(move |y| {
        (0..w).map(move |x| {
            let r = framed.camera.ray(crate::camera::screen_point(x, y, glam::DVec2::splat(0.5), w, h));
            prep.accel.closest(r.origin, r.dir, 0.0, f32::INFINITY).map(|h| prep.world.object_of(h.tri))
        })
    })
}

/// The pixels `objects_seen` reads.
const SEEN_PIXELS: f64 = 64.0 * 48.0;

#[test]
fn objects_on_a_floor_or_a_sweep_are_framed_without_it() {
    use crate::scene::default::{cuboid, ellipsoid};
    use crate::scene::{Material, Mesh, Object, Scene};
    let share = |setting: Option<(Mesh, DVec3)>| {
        let mut s = Scene::default();
        s.materials.push(Material::default());
        s.meshes.push(ellipsoid("ball", glam::Vec3::splat(1.0), 12, 24, 0));
        s.objects.push(Object { name: "ball".into(), mesh: 0, transform: glam::DMat4::from_translation(DVec3::Y) });
        if let Some((mesh, at)) = setting {
            s.meshes.push(mesh);
            s.objects.push(Object { name: "setting".into(), mesh: 1, transform: glam::DMat4::from_translation(at) });
        }
        let prep = Prepared::new(s);
        let framed = frame_camera(&params(), &prep.world, &prep.accel).unwrap();
        let (mut ball, mut floor) = (0, 0);
        for seen in objects_seen(&framed, &prep) {
            match seen {
                Some(0) => ball += 1,
                Some(_) => floor += 1,
                None => {}
            }
        }
        (ball as f64 / SEEN_PIXELS, floor as f64 / SEEN_PIXELS)
    };
    let (alone, _) = share(None);
    assert!(alone > 0.4, "{alone}");
    // A 40 m floor; a studio sweep 8 m wide, curving up into its wall 3 m behind the ball.
    let floor = (cuboid("floor", glam::Vec3::new(40.0, 0.02, 40.0), 0), DVec3::new(0.0, -0.01, 0.0));
    let sweep = (crate::scene::test_sweep(&crate::scene::sweep_profile(0.0), 8.0, false), DVec3::ZERO);
    for (what, setting) in [("floor", floor), ("sweep", sweep)] {
        let (ball, floor) = share(Some(setting));
        assert!(ball > 0.5 * alone, "the ball on the {what} {ball:.3}, alone {alone:.3}");
        assert!(floor > 0.05, "the {what} is in the picture: {floor:.3}");
    }
}

/// An open room (a floor and two walls, separate slabs) seen by the scene's camera from outside
/// its corner: framed around the furniture, the walls and floor run past the canvas; before, the
/// corner was framed whole, a box floating in black with the furniture small in it.
#[test]
fn an_open_room_is_framed_around_its_furniture() {
    use crate::scene::default::{cuboid, ellipsoid};
    use crate::scene::{Material, Object, Projection, Scene, SceneCamera};
    let mut s = Scene::default();
    s.materials.push(Material::default());
    let put = |s: &mut Scene, mesh: crate::scene::Mesh, at: DVec3| {
        s.meshes.push(mesh);
        let name = format!("o{}", s.objects.len());
        s.objects.push(Object { name, mesh: s.meshes.len() - 1, transform: glam::DMat4::from_translation(at) });
    };
    // The furniture first (objects 0 and 1): a table-sized box and a ball.
    put(&mut s, cuboid("table", glam::Vec3::new(1.1, 0.75, 0.7), 0), DVec3::new(0.2, 0.375, -0.3));
    put(&mut s, ellipsoid("ball", glam::Vec3::splat(0.3), 12, 24, 0), DVec3::new(-0.6, 0.3, 0.2));
    put(&mut s, cuboid("floor", glam::Vec3::new(3.0, 0.05, 3.0), 0), DVec3::new(0.0, -0.025, 0.0));
    put(&mut s, cuboid("back", glam::Vec3::new(3.0, 2.5, 0.05), 0), DVec3::new(0.0, 1.25, -1.525));
    put(&mut s, cuboid("left", glam::Vec3::new(0.05, 2.5, 3.0), 0), DVec3::new(-1.525, 1.25, 0.0));
    let eye = DVec3::new(2.8, 1.7, 2.2);
    s.camera = Some(SceneCamera {
        position: eye,
        forward: (DVec3::new(-0.3, 0.7, -0.5) - eye).normalize(),
        up: DVec3::Y,
        projection: Projection::Perspective { yfov: 0.9 },
        focus_distance: None,
    });
    let prep = Prepared::new(s);
    assert_eq!(prep.world.backdrops.iter().map(|b| b.object).collect::<Vec<_>>(), vec![2, 3, 4]);
    let framed = frame_camera(&params(), &prep.world, &prep.accel).unwrap();
    let (mut furniture, mut nothing) = (0, 0);
    for seen in objects_seen(&framed, &prep) {
        match seen {
            Some(0 | 1) => furniture += 1,
            Some(_) => {}
            None => nothing += 1,
        }
    }
    let share = |n: i32| n as f64 / SEEN_PIXELS;
    assert!(share(furniture) > 0.25, "the furniture covers {:.3} ({})", share(furniture), framed.describe(&prep.world));
    assert!(
        share(nothing) < 0.15,
        "{:.3} of the canvas shows nothing ({})",
        share(nothing),
        framed.describe(&prep.world)
    );
    // Rendered, the floor and the walls run on past their edges (`trace::run_on`): every pixel
    // shows the room.
    let tracer = crate::trace::Tracer {
        world: &prep.world,
        accel: &prep.accel,
        rig: None,
        background: glam::Vec3::ZERO,
        seed: 0,
    };
    let mut film = crate::film::Film::new(64, 48, 1);
    tracer.render(&mut film, &|_, p| framed.camera.ray(p), None, None, &crate::progress::Progress::silent());
    let missed = film.hits.iter().filter(|h| h.object == crate::film::NO_HIT).count();
    assert!(nothing > 0 && missed == 0, "{missed} of {nothing} pixels left showing nothing");
    // What the rays hit stays what they hit (only an edge of the floor may give way to it).
    let changed = objects_seen(&framed, &prep)
        .zip(&film.hits)
        .filter(|(seen, hit)| seen.is_some_and(|o| o != hit.object))
        .count();
    assert!(share(changed as i32) < 0.01, "{changed} pixels show another object than they hit");
}
