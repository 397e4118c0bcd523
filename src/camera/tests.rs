//! Camera maths: convergence, angular span, orientation, limits, and a property test that no
//! camera ever yields a NaN or zero direction.

use glam::{DVec2, DVec3, Vec3};
use proptest::prelude::*;

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
    match kind % 5 {
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
        _ => Box::new(Orthographic { frame: f, height: 2.0, aspect, focus: 5.0, clip_radius: 1.0 }),
    }
}

proptest! {
    #[test]
    fn no_camera_yields_a_nan_or_zero_direction(
        kind in 0u8..5,
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
