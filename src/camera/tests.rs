//! Camera maths: convergence, angular span, orientation, limits, and a property test that no
//! camera ever yields a NaN or zero direction.

use glam::{DVec2, DVec3, Vec3};
use proptest::prelude::*;

use super::warp::Warp;
use super::*;

fn frame() -> CameraFrame {
    CameraFrame::new(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z, DVec3::Y).unwrap().0
}

/// Distance from point `c` to the line of `r`.
fn line_distance(r: &CameraRay, c: Vec3) -> f32 {
    (c - r.origin).cross(r.dir).length()
}

fn angle(a: Vec3, b: Vec3) -> f64 {
    (a.dot(b) as f64).clamp(-1.0, 1.0).acos().to_degrees()
}

fn spherical(alpha_deg: f64, aspect: f64) -> Spherical {
    let a = alpha_deg.to_radians();
    Spherical { frame: frame(), centre: DVec3::ZERO, distance: 3.0, angle_x: a, angle_y: a / aspect, clip_radius: 10.0 }
}

const GRID: [f64; 5] = [-0.5, -0.25, 0.0, 0.25, 0.5];

#[test]
fn spherical_rays_converge_on_the_focal_centre() {
    let cam = spherical(140.0, 4.0 / 3.0);
    for x in GRID {
        for y in GRID {
            let r = cam.ray(DVec2::new(x, y));
            assert!(line_distance(&r, Vec3::ZERO) < 1e-5, "({x}, {y})");
            assert!((r.focal_point() - Vec3::ZERO).length() < 1e-5);
            assert!((r.dir.length() - 1.0).abs() < 1e-6);
        }
    }
}

#[test]
fn spherical_spans_the_convergence_angle() {
    for alpha in [30.0, 90.0, 140.0, 180.0] {
        let cam = spherical(alpha, 1.0);
        let l = cam.ray(DVec2::new(-0.5, 0.0)).dir;
        let r = cam.ray(DVec2::new(0.5, 0.0)).dir;
        assert!((angle(l, r) - alpha).abs() < 1e-3, "horizontal {alpha}: {}", angle(l, r));
        let b = cam.ray(DVec2::new(0.0, -0.5)).dir;
        let t = cam.ray(DVec2::new(0.0, 0.5)).dir;
        assert!((angle(b, t) - alpha).abs() < 1e-3, "vertical {alpha}");
    }
    // The listing's alpha_y = alpha / aspect.
    let cam = spherical(120.0, 2.0);
    let b = cam.ray(DVec2::new(0.0, -0.5)).dir;
    let t = cam.ray(DVec2::new(0.0, 0.5)).dir;
    assert!((angle(b, t) - 60.0).abs() < 1e-3);
}

#[test]
fn spherical_central_ray_is_the_view_direction_and_the_image_is_not_mirrored() {
    let cam = spherical(140.0, 1.0);
    let c = cam.ray(DVec2::ZERO);
    assert!((c.dir - Vec3::NEG_Z).length() < 1e-6);
    assert!((c.origin - Vec3::new(0.0, 0.0, 3.0)).length() < 1e-5);
    // The right of the image starts on the scene's right (+x) and sees its right flank.
    let r = cam.ray(DVec2::new(0.5, 0.0));
    assert!(r.origin.x > 0.0 && r.dir.x < 0.0);
    let t = cam.ray(DVec2::new(0.0, 0.5));
    assert!(t.origin.y > 0.0 && t.dir.y < 0.0);
}

#[test]
fn spherical_360_surrounds_the_centre() {
    let cam = spherical(360.0, 1.0);
    let back = cam.ray(DVec2::new(0.5, 0.0));
    assert!((back.dir - Vec3::Z).length() < 1e-5, "{:?}", back.dir);
}

#[test]
fn cylindrical_rays_meet_the_vertical_focal_line_and_rows_map_to_height() {
    let cam = Cylindrical {
        frame: frame(),
        centre: DVec3::ZERO,
        distance: 3.0,
        angle_x: 140f64.to_radians(),
        height: 2.0,
        clip_radius: 10.0,
    };
    for x in GRID {
        for y in GRID {
            let r = cam.ray(DVec2::new(x, y));
            let on_axis = Vec3::new(0.0, (y * 2.0) as f32, 0.0);
            assert!(line_distance(&r, on_axis) < 1e-5, "({x}, {y})");
            assert!(r.dir.y.abs() < 1e-6, "rays are horizontal");
            assert!((r.focal_point() - on_axis).length() < 1e-5);
        }
    }
    let l = cam.ray(DVec2::new(-0.5, 0.3)).dir;
    let r = cam.ray(DVec2::new(0.5, 0.3)).dir;
    assert!((angle(l, r) - 140.0).abs() < 1e-3);
}

#[test]
fn planar_rays_converge_on_the_focal_point_of_eq_4_1() {
    let alpha = 90f64.to_radians();
    let s = 2.0;
    let cam = Planar::new(frame(), s, 1.5, alpha, 100.0);
    // f_p = c_p + s cot(alpha/2) / 2 c_d = (0, 0, 5) - (0, 0, 1) = (0, 0, 4).
    let fp = cam.focal_point().unwrap();
    assert!((fp - DVec3::new(0.0, 0.0, 4.0)).length() < 1e-9);
    for x in GRID {
        for y in GRID {
            let r = cam.ray(DVec2::new(x, y));
            assert!(line_distance(&r, fp.as_vec3()) < 1e-5);
            // origin = c_p + u y s + h x s r.
            let o = Vec3::new((x * s * 1.5) as f32, (y * s) as f32, 5.0);
            assert!((r.origin - o).length() < 1e-5, "origin {:?} vs {o:?}", r.origin);
            assert!(r.dir.z < 0.0, "rays point into the scene (the thesis's sign is a typo)");
        }
    }
    // Vertical convergence angle is alpha.
    let b = cam.ray(DVec2::new(0.0, -0.5)).dir;
    let t = cam.ray(DVec2::new(0.0, 0.5)).dir;
    assert!((angle(b, t) - 90.0).abs() < 1e-3);
}

#[test]
fn planar_tends_to_orthographic_without_overflow() {
    for alpha in [0.0, 1e-12, 1e-6, 1e-3] {
        let cam = Planar::new(frame(), 2.0, 1.0, alpha, 100.0);
        for x in GRID {
            let r = cam.ray(DVec2::new(x, 0.4));
            assert!(r.origin.is_finite() && r.dir.is_finite());
            assert!(r.dir.dot(Vec3::NEG_Z) > 0.999_999, "alpha {alpha}: {:?}", r.dir);
        }
    }
    assert!(Planar::new(frame(), 2.0, 1.0, 0.0, 1.0).focal_point().is_none());
}

#[test]
fn perspective_rays_leave_the_eye_and_span_the_field_of_view() {
    let cam = Perspective {
        frame: frame(),
        tan_half_fov: (30f64.to_radians()).tan(),
        aspect: 1.0,
        focus: 5.0,
        clip_radius: 100.0,
    };
    for x in GRID {
        let r = cam.ray(DVec2::new(x, 0.1));
        assert!((r.origin - Vec3::new(0.0, 0.0, 5.0)).length() < 1e-6);
    }
    let b = cam.ray(DVec2::new(0.0, -0.5)).dir;
    let t = cam.ray(DVec2::new(0.0, 0.5)).dir;
    assert!((angle(b, t) - 60.0).abs() < 1e-3);
}

#[test]
fn orthographic_rays_are_parallel() {
    let cam = Orthographic { frame: frame(), height: 2.0, aspect: 2.0, focus: 5.0, clip_radius: 100.0 };
    let a = cam.ray(DVec2::new(-0.5, -0.5));
    let b = cam.ray(DVec2::new(0.5, 0.5));
    assert_eq!(a.dir, b.dir);
    assert!((b.origin - a.origin - Vec3::new(4.0, 2.0, 0.0)).length() < 1e-5);
}

#[test]
fn degenerate_frames_are_fixed_or_refused() {
    let (f, fixed) = CameraFrame::new(DVec3::ZERO, DVec3::NEG_Y, DVec3::Y).unwrap();
    assert!(fixed);
    assert!(f.up.dot(f.forward).abs() < 1e-12 && (f.up.length() - 1.0).abs() < 1e-12);
    assert!((f.right.length() - 1.0).abs() < 1e-12);
    assert!(CameraFrame::new(DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_none());
    let (_, fixed) = CameraFrame::new(DVec3::ZERO, DVec3::NEG_Z, DVec3::new(0.0, 1.0, 0.3)).unwrap();
    assert!(!fixed);
}

#[test]
fn far_origins_start_at_the_scene_sphere_without_changing_the_line() {
    let r = finish_ray(DVec3::new(0.0, 0.0, 1e12), DVec3::NEG_Z, 1e12, 1.0);
    assert!(r.origin.z > 1.0 && r.origin.z < 1.1, "{:?}", r.origin);
    assert!((r.focal_point() - Vec3::ZERO).length() < 1e-3);
}

fn any_camera(kind: u8, alpha_frac: f64, aspect: f64) -> Box<dyn Camera> {
    let f = frame();
    match kind % 6 {
        0 => {
            let a = alpha_frac * 360f64.to_radians();
            Box::new(Spherical {
                frame: f,
                centre: DVec3::ZERO,
                distance: 3.0,
                angle_x: a,
                angle_y: a / aspect,
                clip_radius: 1.0,
            })
        }
        1 => Box::new(Cylindrical {
            frame: f,
            centre: DVec3::ZERO,
            distance: 3.0,
            angle_x: alpha_frac * 360f64.to_radians(),
            height: 2.0,
            clip_radius: 1.0,
        }),
        2 => Box::new(Planar::new(f, 2.0, aspect, alpha_frac * 179.999f64.to_radians(), 1.0)),
        3 => Box::new(Perspective {
            frame: f,
            tan_half_fov: (alpha_frac.max(1e-6) * 179.9f64.to_radians() / 2.0).tan(),
            aspect,
            focus: 5.0,
            clip_radius: 1.0,
        }),
        4 => Box::new(Orthographic { frame: f, height: 2.0, aspect, focus: 5.0, clip_radius: 1.0 }),
        _ => Box::new(warped(injective_camera(0, alpha_frac, aspect).model())),
    }
}

proptest! {
    #[test]
    fn no_camera_yields_a_nan_or_zero_direction(
        kind in 0u8..6,
        alpha_frac in prop_oneof![Just(0.0), Just(1.0), 0.0f64..=1.0],
        aspect in prop_oneof![Just(1.0 / 4000.0), Just(4000.0), 0.01f64..100.0],
        x in -0.5f64..=0.5,
        y in -0.5f64..=0.5,
    ) {
        let cam = any_camera(kind, alpha_frac, aspect);
        let r = cam.ray(DVec2::new(x, y));
        prop_assert!(r.origin.is_finite(), "origin {:?}", r.origin);
        prop_assert!(r.dir.is_finite() && (r.dir.length() - 1.0).abs() < 1e-4, "dir {:?}", r.dir);
        prop_assert!(!r.focus.is_nan());
    }
}

/// A camera that maps screen points to rays one to one, and well-conditioned there: angles
/// below 180 degrees for the spherical camera (at 180 its image's left and right edges look
/// along -h and +h, where the row is undefined; beyond, two screen points share a ray), below
/// 360 for the cylindrical one (whose edges then meet), finite fields of view.
fn injective_camera(kind: u8, alpha_frac: f64, aspect: f64) -> Box<dyn Camera> {
    let f = frame();
    match kind % 6 {
        0 => {
            let a = (0.02 + 0.98 * alpha_frac) * 170f64.to_radians();
            let ay = (a / aspect).min(170f64.to_radians());
            Box::new(Spherical {
                frame: f,
                centre: DVec3::ZERO,
                distance: 3.0,
                angle_x: a,
                angle_y: ay,
                clip_radius: 1.0,
            })
        }
        1 => Box::new(Cylindrical {
            frame: f,
            centre: DVec3::ZERO,
            distance: 3.0,
            angle_x: (0.02 + 0.98 * alpha_frac) * 350f64.to_radians(),
            height: 2.0,
            clip_radius: 1.0,
        }),
        2 => Box::new(Planar::new(f, 2.0, aspect, alpha_frac * 170f64.to_radians(), 1.0)),
        3 => Box::new(Perspective {
            frame: f,
            tan_half_fov: ((0.02 + 0.98 * alpha_frac) * 170f64.to_radians() / 2.0).tan(),
            aspect,
            focus: 5.0,
            clip_radius: 1.0,
        }),
        4 => Box::new(Orthographic { frame: f, height: 2.0, aspect, focus: 5.0, clip_radius: 1.0 }),
        _ => Box::new(warped(injective_camera(0, alpha_frac, aspect).model())),
    }
}

/// `inner` through a canvas warp that widens the middle and narrows the sides, unevenly.
fn warped(inner: CameraModel) -> Warped {
    let knots = |v: Vec<f64>| Warp::try_from(v).unwrap();
    Warped { inner, x: knots(vec![-0.5, -0.42, -0.1, 0.25, 0.4, 0.5]), y: knots(vec![-0.5, -0.2, 0.3, 0.5]) }
}

/// A point `fraction` of the way along the ray of `p` from the camera surface to its focal
/// point (or 4 units along parallel rays).
fn point_on_ray(cam: &dyn Camera, p: DVec2, fraction: f64) -> (DVec3, f64) {
    let r = cam.ray(p);
    let reach = if r.surface_focus().is_finite() { r.surface_focus() } else { 4.0 };
    let depth = fraction * reach;
    (r.surface_origin() + r.dir.as_dvec3() * depth, depth)
}

proptest! {
    /// `project` is the exact inverse of `ray`: a point on the ray of a screen point, before
    /// its focal point, projects back to that screen point at its distance along the ray.
    #[test]
    fn project_inverts_ray(
        kind in 0u8..6,
        alpha_frac in 0.0f64..=1.0,
        aspect in 0.25f64..4.0,
        x in -0.5f64..=0.5,
        y in -0.5f64..=0.5,
        fraction in 0.01f64..0.99,
    ) {
        let cam = injective_camera(kind, alpha_frac, aspect);
        let p = DVec2::new(x, y);
        let (q, depth) = point_on_ray(cam.as_ref(), p, fraction);
        let back = cam.project(q).expect("a point on a ray is seen");
        // f32 rays: about 1e-7 of the scene's size, up to ~3e-5 of the screen at grazing angles
        // (a tenth of a pixel at 1000 px would be 1e-4).
        prop_assert!((back.screen - p).length() < 1e-4, "{p:?} -> {:?}", back.screen);
        // Depth: the planar camera near 170 degrees meets the plane at a grazing angle, which
        // turns the f32 direction's 1e-7 into ~3e-5 of the depth (found by this test).
        prop_assert!((back.depth - depth).abs() < 1e-4 * depth.max(1.0), "{depth} -> {}", back.depth);
        prop_assert!(back.in_view() || (back.screen.abs() - DVec2::splat(0.5)).max_element() < 2e-5);
    }

    /// Beyond 180 degrees two screen points share a ray, so `project` cannot tell which one was
    /// meant; the one it picks still sees the point: its ray passes through it at that depth.
    #[test]
    fn wide_cameras_project_onto_a_ray_through_the_point(
        kind in 0u8..2,
        alpha_frac in 0.5f64..=1.0,
        x in -0.5f64..=0.5,
        y in -0.5f64..=0.5,
        fraction in 0.01f64..0.99,
    ) {
        let cam = any_camera(kind, alpha_frac, 1.0);
        let (q, _) = point_on_ray(cam.as_ref(), DVec2::new(x, y), fraction);
        let back = cam.project(q).unwrap();
        prop_assert!(back.in_view(), "{:?}", back.screen);
        let r = cam.ray(back.screen);
        let reached = r.surface_origin() + r.dir.as_dvec3() * back.depth;
        prop_assert!((reached - q).length() < 1e-5, "{q:?} vs {reached:?}");
    }
}

#[test]
fn points_no_ray_reaches_are_not_projected() {
    let persp = injective_camera(3, 0.3, 1.0);
    assert!(persp.project(DVec3::new(0.0, 0.0, 6.0)).is_none(), "behind the eye");
    let ortho = injective_camera(4, 0.0, 1.0);
    assert!(ortho.project(DVec3::new(0.0, 0.0, 5.5)).is_none(), "behind the view plane");
    let planar = Planar::new(frame(), 2.0, 1.0, 90f64.to_radians(), 1.0);
    // f_p = (0, 0, 4): a point of its focal plane away from it is on no ray.
    assert!(planar.project(DVec3::new(0.5, 0.0, 4.0)).is_none());
    assert_eq!(planar.project(DVec3::new(0.0, 0.0, 4.0)).unwrap().screen, DVec2::ZERO);
    // Beyond the focal point rays have crossed: the point's image is mirrored.
    let beyond = planar.project(DVec3::new(0.2, 0.1, 3.0)).unwrap();
    assert!(beyond.screen.x < 0.0 && beyond.screen.y < 0.0, "{beyond:?}");
    // A spherical camera does not see outside the sphere its rays start on, and sees a point
    // beyond its focal centre through the opposite direction.
    let sph = spherical(140.0, 1.0);
    let out = sph.project(DVec3::new(0.0, 0.0, 3.5)).unwrap();
    assert!((out.depth - 6.5).abs() < 1e-12, "only the ray from the far side reaches it: {out:?}");
    let seen = sph.project(DVec3::new(0.0, 0.0, -1.0)).unwrap();
    assert!((seen.depth - 4.0).abs() < 1e-12 && seen.screen.length() < 1e-12, "{seen:?}");
}

#[test]
fn a_moved_camera_moves_its_rays_and_projects_back() {
    let inner = spherical(140.0, 1.5);
    let rotation = glam::DQuat::from_rotation_y(0.7);
    let moved = Moved { inner: &inner, rotation, translation: DVec3::new(0.1, -0.2, 0.3), clip_radius: 10.0 };
    for (x, y) in [(0.0, 0.0), (0.3, -0.2), (-0.45, 0.4)] {
        let p = DVec2::new(x, y);
        let a = inner.ray(p);
        let b = moved.ray(p);
        let turned = (rotation * a.dir.as_dvec3()).as_vec3();
        assert!((b.dir - turned).length() < 1e-6);
        assert!((b.focal_point().as_dvec3() - moved.point(a.focal_point().as_dvec3())).length() < 1e-5);
        let (q, depth) = point_on_ray(&moved, p, 0.4);
        let back = moved.project(q).unwrap();
        assert!((back.screen - p).length() < 1e-5 && (back.depth - depth).abs() < 1e-5, "{back:?}");
    }
    let f = moved.frame(&inner.frame);
    assert!((f.forward - rotation * DVec3::NEG_Z).length() < 1e-12);
    assert!((f.right - f.forward.cross(f.up)).length() < 1e-12, "still right-handed");
}

/// `centre_rays` gives `ray` bit for bit: at every pixel centre (tabulated), at jittered
/// points (computed), through `CameraModel` too, and for a camera without a table.
#[test]
fn centre_rays_are_the_rays_bit_for_bit() {
    let bits = |r: &CameraRay| {
        (
            r.origin.to_array().map(f32::to_bits),
            r.dir.to_array().map(f32::to_bits),
            r.focus.to_bits(),
            r.skipped.to_bits(),
        )
    };
    let (w, h) = (37u32, 23u32);
    let cameras: Vec<Box<dyn Camera>> = vec![
        Box::new(spherical(200.0, 37.0 / 23.0)),
        Box::new(CameraModel::Spherical(spherical(90.0, 1.0))),
        Box::new(CameraModel::Planar(Planar::new(frame(), 2.0, 1.5, 90f64.to_radians(), 100.0))),
        Box::new(warped(CameraModel::Spherical(spherical(140.0, 37.0 / 23.0)))),
    ];
    for cam in &cameras {
        let rays = cam.centre_rays(w, h);
        for i in 0..(w * h) as usize {
            let (x, y) = (i as u32 % w, i as u32 / w);
            for off in [DVec2::splat(0.5), DVec2::new(0.13, 0.77)] {
                let p = crate::trace::screen_point(x, y, off, w, h);
                assert_eq!(bits(&rays(i, p)), bits(&cam.ray(p)), "pixel {i}, offset {off}");
            }
        }
        // A point another pixel's index does not own is still its own ray.
        let p = crate::trace::screen_point(3, 4, DVec2::splat(0.5), w, h);
        assert_eq!(bits(&rays(0, p)), bits(&cam.ray(p)));
    }
}

/// A warped camera is the inner camera's ray at the warped screen point, and survives being
/// saved beside a facet layout (serde) and read back.
#[test]
fn a_warped_camera_remaps_the_screen_and_round_trips_as_data() {
    let inner = CameraModel::Spherical(spherical(140.0, 1.5));
    let cam = warped(inner.clone());
    for (x, y) in [(0.0, 0.0), (0.3, -0.2), (-0.45, 0.4), (0.5, -0.5)] {
        let p = DVec2::new(x, y);
        let q = DVec2::new(cam.x.to_inner(x), cam.y.to_inner(y));
        assert_eq!(cam.ray(p), inner.ray(q));
    }
    // The ends stay put: the whole inner view is still on the canvas.
    assert_eq!(cam.ray(DVec2::new(-0.5, 0.5)), inner.ray(DVec2::new(-0.5, 0.5)));
    let json = serde_json::to_string(&cam.model()).unwrap();
    let back: CameraModel = serde_json::from_str(&json).unwrap();
    assert_eq!(back, cam.model());
    let broken = json.replace("-0.42", "0.45");
    assert!(serde_json::from_str::<CameraModel>(&broken).is_err(), "knots out of order are refused");
}
