//! One view of the subject framed: the camera placed, its type and size chosen (`frame_view`).

use glam::DVec3;

use super::fit::fit_depth;
use super::probe::{COARSE_PROBE_COLUMNS, NEAR_C_RADII, NearGuard, PROBE_COLUMNS, probe_fill};
use super::subject::Subject;
use super::{FIT_FILL, Framed, Framing, FramingParams, PINHOLE_FILL, TALL_RATIO, centroid_axis, compose};
use crate::accel::Accel;
use crate::camera::{Camera, CameraFrame, CameraKind, Cylindrical, Orthographic, Perspective, Planar, Spherical};
use crate::error::{Error, Result};
use crate::scene::{Projection, World};

/// A view of the subject: the front view turned about the up axis by `yaw` and tilted down by
/// `tilt` (radians), with the camera type when the view fixes it (None: as asked). `centroid`:
/// the view axis (from which `compose` places and centres C) passes through the centroid of the
/// scene's sampled vertices instead of its bounding sphere's centre. `guarded`: candidates that
/// magnify a part near C over most of the subject are refused (`NearGuard`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct View {
    pub(super) tilt: f64,
    pub(super) yaw: f64,
    pub(super) kind: Option<CameraKind>,
    pub(super) centroid: bool,
    pub(super) guarded: bool,
}

impl View {
    pub(super) const FRONT: View = View { tilt: 0.0, yaw: 0.0, kind: None, centroid: false, guarded: false };
}

/// How `frame_view` composes: every candidate on `FIT_SAMPLES`, every candidate on
/// `COARSE_SAMPLES` with a smaller probe (to rank views), or one candidate (its
/// `Composition::candidate`) on `FIT_SAMPLES`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Search {
    Full,
    Coarse,
    Only(usize),
}

/// `frame_camera` for one `view` (the front turned and tilted, see `View`) searched as
/// `search` says, and what `compose` chose, when it composed.
pub(super) fn frame_view(
    params: &FramingParams,
    world: &World,
    accel: &Accel,
    subject: &Subject,
    view: View,
    search: Search,
) -> Result<(Framed, Option<compose::Composition>)> {
    let View { tilt, yaw, kind: view_kind, centroid, guarded } = view;
    let mut warnings = Vec::new();
    let aspect = params.width as f64 / params.height as f64;
    let sim = world.to_render;
    // The scene's sphere bounds every ray; the subject's (the scene without its backdrops,
    // `Subject`) is what the cameras are framed around.
    let clip = (world.radius as f64).max(1e-9) * 1.001;
    let (centre, radius) = (subject.centre, subject.radius);
    let scene_cam = world.camera.as_ref();

    // 1. The view frame: explicit parameters, else the scene's camera, else looking down -Z.
    let target = params.target.map(|t| sim.point_f64(DVec3::from(t)));
    let position = params.position.map(|p| sim.point_f64(DVec3::from(p)));
    let (forward, up) = match (position, target) {
        (Some(p), Some(t)) => (t - p, None),
        (Some(p), None) => (-p, None),
        (None, _) => match scene_cam {
            Some(c) => (c.forward, Some(c.up)),
            None => subject.upright.map_or((DVec3::NEG_Z, None), |u| (u.forward, Some(u.up))),
        },
    };
    let up = params.up.map(DVec3::from).or(up).unwrap_or(DVec3::Y);
    let forward = if forward.length_squared() > 0.0 { forward } else { DVec3::NEG_Z };
    let forward = match (forward.normalize().reject_from(up).try_normalize(), up.try_normalize()) {
        (Some(level), Some(u)) if tilt != 0.0 || yaw != 0.0 => {
            // Turned about the up axis by `yaw` (counter-clockwise seen from above), then tilted.
            let level = level * yaw.cos() + u.cross(level) * yaw.sin();
            level * tilt.cos() - u * tilt.sin()
        }
        _ => forward,
    };
    let (mut frame, fixed) = CameraFrame::new(DVec3::ZERO, forward, up)
        .ok_or_else(|| Error::setting("camera_up", "cannot build a camera frame from these vectors"))?;
    if fixed {
        warnings.push("camera up vector is parallel to the view direction; replaced by a perpendicular axis".into());
    }
    let fwd = frame.forward;
    // 2. The camera position if one is given (parameters, target, or the scene's camera).
    let given_position = match (position, target) {
        (Some(p), _) => Some(p),
        (None, Some(t)) => Some(t - fwd * 3.0 * radius),
        (None, None) => scene_cam.map(|c| c.position),
    };
    // The point of the view axis level with the scene's centre: C is placed from here.
    let points = subject.points(search == Search::Coarse);
    let axis = match given_position {
        Some(p) => p + fwd * (centre - p).dot(fwd),
        None if centroid => centroid_axis(points, fwd, centre).unwrap_or(centre),
        None => centre,
    };
    let extent = |v: DVec3| {
        let (lo, hi) =
            points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.dot(v)), hi.max(p.dot(v))));
        if lo.is_finite() { (lo, hi) } else { (0.0, 0.0) }
    };
    let (ext_r, ext_u, ext_f) = (extent(frame.right), extent(frame.up), extent(frame.forward));
    let size = DVec3::new(ext_r.1 - ext_r.0, ext_u.1 - ext_u.0, ext_f.1 - ext_f.0);
    let mut kind = match view_kind.unwrap_or(params.kind) {
        CameraKind::Auto => {
            if size.y >= TALL_RATIO * size.x.max(size.z) {
                CameraKind::Cylindrical
            } else {
                CameraKind::Spherical
            }
        }
        k => k,
    };
    let gltf_fov = scene_cam.and_then(|c| match c.projection {
        Projection::Perspective { yfov } => Some(yfov.to_degrees()),
        _ => None,
    });
    let mut angle_deg = params.angle_deg(kind, gltf_fov);
    if kind == CameraKind::Planar && !(0.0..180.0).contains(&angle_deg) {
        return Err(Error::setting(
            "ambiguity",
            format!("{angle_deg} deg is impossible for the planar camera: [0, 180)"),
        ));
    }
    let alpha = angle_deg.to_radians();
    // The scene's own focus applies only to its own camera.
    let scene_focus =
        if position.is_none() && target.is_none() { scene_cam.and_then(|c| c.focus_distance) } else { None };
    let focus = params.focus_distance.map(|f| sim.length(f)).or(scene_focus);
    let size_setting = params.size.map(|s| sim.length(s));
    let fit_fill = params.fill.unwrap_or(FIT_FILL);
    let pinhole_fill = params.fill.unwrap_or(PINHOLE_FILL);
    let view_height;
    let mut cropped = None;

    let camera: Box<dyn Camera>;
    let focal_centre;
    let mut composition = None;
    match kind {
        CameraKind::Spherical | CameraKind::Cylindrical | CameraKind::Auto => {
            let half =
                if kind == CameraKind::Spherical { (alpha / 2.0, alpha / aspect / 2.0) } else { (alpha / 2.0, 0.0) };
            let distance_for = |c: DVec3| match (focus, given_position) {
                (Some(f), _) => f,
                (None, Some(p)) => (c - p).length().max(1e-9),
                // Rays start on a sphere enclosing the scene.
                (None, None) => (c - centre).length() + 1.5 * radius,
            };
            // `compose` fits C and the spans together when the angle is the renderer's to
            // choose; a given ambiguity, or a user's focus from a user's camera, is framed as
            // `fit` frames it.
            let composing = params.framing == Framing::Compose
                && params.ambiguity.is_none()
                && !(focus.is_some() && given_position.is_some());
            let fill_of = |kind: CameraKind, k: &compose::Composition| {
                let distance = distance_for(k.centre);
                let frame = CameraFrame { position: k.centre - fwd * distance, ..frame };
                let camera: Box<dyn Camera> = if kind == CameraKind::Cylindrical {
                    Box::new(Cylindrical {
                        frame,
                        centre: k.centre,
                        distance,
                        angle_x: k.angle_x,
                        height: k.height,
                        clip_radius: clip,
                    })
                } else {
                    Box::new(Spherical {
                        frame,
                        centre: k.centre,
                        distance,
                        angle_x: k.angle_x,
                        angle_y: k.angle_y,
                        clip_radius: clip,
                    })
                };
                let columns = if search == Search::Coarse { COARSE_PROBE_COLUMNS } else { PROBE_COLUMNS };
                let guard = guarded.then_some(NearGuard {
                    centre: k.centre,
                    line: (kind == CameraKind::Cylindrical).then_some(frame.up),
                    within: NEAR_C_RADII * radius,
                });
                probe_fill(camera.as_ref(), accel, aspect, columns, guard.as_ref())
            };
            let margin = params.fill.unwrap_or(compose::COMPOSE_FILL);
            let run = |kind: CameraKind| match search {
                Search::Only(i) => {
                    compose::compose_candidate(points, kind, &frame, axis, aspect, radius, margin, i, &|k| {
                        fill_of(kind, k)
                    })
                }
                _ => compose::compose(points, kind, &frame, axis, aspect, radius, margin, &|k| fill_of(kind, k)),
            };
            let composed = composing.then(|| {
                let first = run(kind);
                // `auto` on a tall scene: the thesis's cylindrical camera, unless the spherical
                // one composes it better (less stretch for the same fill, or more fill).
                if params.kind == CameraKind::Auto && view_kind.is_none() && kind == CameraKind::Cylindrical {
                    let other = run(CameraKind::Spherical);
                    if other.better_than(&first) {
                        return (CameraKind::Spherical, other);
                    }
                }
                (kind, first)
            });
            if let Some((k, _)) = composed {
                kind = k;
            }
            let composed = composed.map(|(_, k)| k);
            composition = composed;
            let framed_c = || match (params.framing, composed) {
                (_, Some(k)) => k.centre,
                (Framing::Centre, _) => axis,
                _ => axis + fwd * fit_depth(points, kind, &frame, axis, half, radius, fit_fill),
            };
            let (alpha, alpha_y, band) = match composed {
                Some(k) => (k.angle_x, k.angle_y, Some(k.height)),
                None => (alpha, alpha / aspect, None),
            };
            angle_deg = alpha.to_degrees();
            let c = match (focus, given_position) {
                (Some(f), Some(p)) => p + fwd * f,
                _ => framed_c(),
            };
            let distance = distance_for(c);
            frame.position = c - fwd * distance;
            if kind == CameraKind::Cylindrical {
                let height = size_setting.or(band).unwrap_or((size.y * 1.08).max(1e-6));
                // The band is centred on the scene's vertical middle, or where the composition
                // cropped a tall subject (not under a band height of the user's).
                let lift = composed.filter(|_| size_setting.is_none()).map_or(0.0, |k| k.lift);
                cropped = match lift {
                    l if l > 0.0 => Some(super::Cropped::Foot),
                    l if l < 0.0 => Some(super::Cropped::Top),
                    _ => None,
                };
                let centre = c + frame.up * (0.5 * (ext_u.0 + ext_u.1) - c.dot(frame.up) + lift);
                camera = Box::new(Cylindrical { frame, centre, distance, angle_x: alpha, height, clip_radius: clip });
                focal_centre = Some(centre);
                view_height = Some(height);
            } else {
                camera = Box::new(Spherical {
                    frame,
                    centre: c,
                    distance,
                    angle_x: alpha,
                    angle_y: alpha_y,
                    clip_radius: clip,
                });
                focal_centre = Some(c);
                view_height = None;
            }
        }
        CameraKind::Planar => {
            let tan = (alpha / 2.0).tan();
            let half = ((aspect * tan).atan(), alpha / 2.0);
            // Plane centre c_p and size s; L = s cot(alpha/2) / 2 follows (eq 4.1).
            let (cp, s) = if let Some(f) = focus {
                // The plane at the camera position, f_p at the focus distance.
                let cp = given_position.unwrap_or(axis - fwd * f);
                (cp, size_setting.unwrap_or(2.0 * f * tan))
            } else if alpha < 1e-5 {
                // The orthographic limit (the fit below would put f_p a million radii away):
                // f_p at infinity, the plane frames the scene.
                let s = size_setting.unwrap_or((ext_u.1 - ext_u.0).max((ext_r.1 - ext_r.0) / aspect) / pinhole_fill);
                (axis - fwd * 3.0 * radius, s.max(1e-9))
            } else {
                let fp = match params.framing {
                    Framing::Centre => axis,
                    Framing::Fit | Framing::Compose => {
                        axis + fwd * fit_depth(points, kind, &frame, axis, half, radius, fit_fill)
                    }
                };
                match size_setting {
                    Some(s) => (fp - fwd * (s / (2.0 * tan)), s),
                    None => {
                        // The plane just in front of the scene; f_p at C.
                        let near = points.iter().map(|p| (*p - axis).dot(fwd)).fold(f64::INFINITY, f64::min);
                        let near = if near.is_finite() { near } else { -radius };
                        let cp = axis + fwd * (near - 0.5 * radius);
                        let l = (fp - cp).dot(fwd).max(1e-9);
                        (cp, 2.0 * l * tan)
                    }
                }
            };
            frame.position = cp;
            let planar = Planar::new(frame, s.max(1e-12), aspect, alpha, clip);
            view_height = Some(planar.size);
            focal_centre = planar.focal_point();
            camera = Box::new(planar);
        }
        CameraKind::Perspective => {
            let tan_half = (alpha / 2.0).tan();
            let half_min = if aspect >= 1.0 { tan_half } else { tan_half * aspect };
            let p = given_position.unwrap_or_else(|| {
                // The bounding sphere's outline fills `fill` of the smaller image side.
                let rho = (pinhole_fill * half_min).atan();
                centre - fwd * (radius / rho.sin())
            });
            frame.position = p;
            let f = focus.unwrap_or_else(|| (centre - p).dot(fwd).max(1e-6));
            camera = Box::new(Perspective { frame, tan_half_fov: tan_half, aspect, focus: f, clip_radius: clip });
            focal_centre = None;
            view_height = None;
        }
        CameraKind::Orthographic => {
            let gltf_height = scene_cam.and_then(|c| match c.projection {
                Projection::Orthographic { ymag } if params.position.is_none() => Some(2.0 * ymag),
                _ => None,
            });
            let height = size_setting.or(gltf_height).unwrap_or_else(|| 2.0 * radius / pinhole_fill / aspect.min(1.0));
            let p = given_position.unwrap_or(centre - fwd * 3.0 * radius);
            frame.position = p;
            let f = focus.unwrap_or_else(|| (centre - p).dot(fwd).max(1e-6));
            camera = Box::new(Orthographic { frame, height, aspect, focus: f, clip_radius: clip });
            focal_centre = None;
            view_height = Some(height);
        }
    }
    Ok((Framed { camera, kind, angle_deg, view_height, focal_centre, frame, warnings, cropped }, composition))
}
