//! Choosing a camera's position, focal centre and size from what was asked and the scene
//! (render space, where the scene's bounding sphere is centred at the origin with radius ~1).
//!
//! Every ray of a converging cubist camera passes through its focal centre C, so the picture
//! is the scene seen along lines through C. With C inside an object the picture is a
//! magnified radial map of the surface around C (SPEC "Framing"). The default framing
//! (`fit`) therefore puts C on the view axis *behind* the scene, as close as it can while
//! every vertex stays within `FIT_FILL` of the convergence half-angles: the whole object is
//! in view, seen around its sides, with a margin of background. `--framing centre` puts C
//! at the centre of the bounding box (the thesis's literal choice). `auto` picks the
//! cylindrical camera for tall scenes (height >= `TALL_RATIO` x width and depth), as the
//! thesis does for standing figures, and the spherical camera otherwise; under `compose` a tall
//! scene is composed with both and the spherical camera is kept when it composes it better
//! (`compose` step 5). When the renderer chooses the view and the front fills under
//! `FILL_FLOOR`, `frame_camera` also tries the subject's broad side.

use glam::DVec3;

use super::fit::fit_depth;
use super::subject::{Subject, View as SceneView};
use super::{
    Camera, CameraFrame, CameraKind, CameraModel, Cylindrical, Orthographic, Perspective, Planar, Spherical, Warped,
    compose,
};
use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::scene::{Projection, World};

/// Fraction of the convergence half-angles the scene fills under `fit` (setting `fill`).
pub const FIT_FILL: f64 = 0.8;
/// Fraction of the image the scene's outline fills for perspective/orthographic defaults
/// (setting `fill`).
pub const PINHOLE_FILL: f64 = 0.9;
/// Height / width ratio from which `auto` picks the cylindrical camera.
pub const TALL_RATIO: f64 = 1.6;
/// Vertices sampled for fitting (every n-th triangle corner beyond this many).
const FIT_SAMPLES: usize = 30_000;
/// Vertices sampled to rank the other views when the front fills under `FILL_FLOOR` (a
/// coarse search finds the best view and its candidate, then only that one is composed on
/// `FIT_SAMPLES`).
const COARSE_SAMPLES: usize = 3_000;

/// Where a cubist camera's focal centre goes when no focus distance is given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Framing {
    /// Behind the scene's centre, so the whole scene fits the convergence angle.
    Fit,
    /// At the centre of the scene's bounding box (the thesis's literal default).
    Centre,
    /// Per scene: C as close behind the scene as the cameras allow and the horizontal and
    /// vertical spans fitted to it, so the subject fills the canvas (`compose`).
    Compose,
}

/// What framing needs: the camera asked for, its angle, where it is and what it looks at
/// (scene units; None: chosen from the scene), and the image's size.
#[derive(Clone, Debug, PartialEq)]
pub struct FramingParams {
    pub kind: CameraKind,
    /// Convergence angle of cubist cameras, the perspective camera's vertical field of view,
    /// degrees. None: 140 for cubist cameras, the glTF camera's (else 60) for perspective.
    pub ambiguity: Option<f64>,
    pub framing: Framing,
    pub focus_distance: Option<f64>,
    pub position: Option<[f64; 3]>,
    pub target: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    /// Planar plane height, orthographic view height, cylindrical band height.
    pub size: Option<f64>,
    /// Fraction of the view the scene fills under automatic framing (None: `FIT_FILL` for
    /// cubist cameras, `PINHOLE_FILL` for the others).
    pub fill: Option<f64>,
    pub width: u32,
    pub height: u32,
}

/// The convergence angle of cubist cameras when none is given, degrees (the middle of the
/// thesis's recommended 120-150).
pub const DEFAULT_ANGLE: f64 = 140.0;
/// The perspective camera's field of view when neither the parameters nor the glTF give one.
pub const DEFAULT_FOV: f64 = 60.0;

impl FramingParams {
    /// The convergence angle (or field of view) in degrees actually used by `kind`.
    pub fn angle_deg(&self, kind: CameraKind, gltf_yfov_deg: Option<f64>) -> f64 {
        match (self.ambiguity, kind) {
            (Some(a), _) => a,
            (None, CameraKind::Perspective) => gltf_yfov_deg.unwrap_or(DEFAULT_FOV),
            (None, _) => DEFAULT_ANGLE,
        }
    }
}

/// A camera with what was decided for it, for `--verbose` and the add-on.
pub struct Framed {
    pub camera: Box<dyn Camera>,
    pub kind: CameraKind,
    /// Convergence angle or field of view, degrees.
    pub angle_deg: f64,
    /// View height of the orthographic camera, plane height s of the planar camera, band
    /// height of the cylindrical camera: render units (what a reference renderer needs).
    pub view_height: Option<f64>,
    /// Focal centre (point, or the centre of the focal line), render space, when there is one.
    pub focal_centre: Option<DVec3>,
    pub frame: CameraFrame,
    pub warnings: Vec<String>,
}

impl Framed {
    pub fn describe(&self, world: &World) -> String {
        let mut s = format!("{} camera, {:.1} deg", self.kind, self.angle_deg);
        if let Some(c) = self.focal_centre {
            let w = world.to_render.inverse_point(c.as_vec3());
            s += &format!(", focal centre ({:.4}, {:.4}, {:.4})", w.x, w.y, w.z);
        }
        if let Some(w) = self.warped() {
            s += &format!(", canvas warped up to {:.2}x", w.x.max_scale().max(w.y.max_scale()));
        }
        s
    }

    /// The canvas warp the camera is seen through (`warp_canvas`), when it is.
    pub fn warped(&self) -> Option<Warped> {
        match self.camera.model() {
            CameraModel::Warped(w) => Some(*w),
            _ => None,
        }
    }
}

/// The share of the canvas under which `compose` also tries the subject's broad side: a
/// subject seen edge-on (a fox head-on, a board) fills little from the front.
pub const FILL_FLOOR: f64 = 0.3;
/// How much wider than from the front the subject's broad side must be for the turned view to
/// be tried (a subject about as wide from every side gains nothing from turning).
pub const BROAD_SIDE_RATIO: f64 = 1.2;
/// Steps of the turn searched for the broad side, degrees (over -90..90: a half turn shows
/// every width, the view turned by at most a quarter turn from the front).
const BROAD_SIDE_STEP_DEG: f64 = 15.0;

/// A view of the subject: the front view turned about the up axis by `yaw` and tilted down by
/// `tilt` (radians), with the camera type when the view fixes it (None: as asked). `centroid`:
/// the view axis (from which `compose` places and centres C) passes through the centroid of the
/// scene's sampled vertices instead of its bounding sphere's centre. `guarded`: candidates that
/// magnify a part near C over most of the subject are refused (`NearGuard`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct View {
    tilt: f64,
    yaw: f64,
    kind: Option<CameraKind>,
    centroid: bool,
    guarded: bool,
}

impl View {
    const FRONT: View = View { tilt: 0.0, yaw: 0.0, kind: None, centroid: false, guarded: false };
}

/// How `frame_view` composes: every candidate on `FIT_SAMPLES`, every candidate on
/// `COARSE_SAMPLES` with a smaller probe (to rank views), or one candidate (its
/// `Composition::candidate`) on `FIT_SAMPLES`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Search {
    Full,
    Coarse,
    Only(usize),
}

/// Chooses the camera's parameters for `world` (SPEC "Framing"; see the module doc);
/// `accel` (its BVH) lets `compose` measure its candidates' fill by a tiny trace.
///
/// The broad side: when the view is the renderer's own (no camera in the scene or the
/// settings) and `compose` fills under `FILL_FLOOR` of the canvas from the front, the broad
/// side is composed too and kept when it fills clearly more (by 1 / `compose::NEAR_BEST`):
/// - the broad side (`broad_side_yaw`), when the subject is at least `BROAD_SIDE_RATIO` wider
///   from there: a thin subject seen edge-on (a figure walking across the view, a plank, a fish)
///   fills a landscape canvas only by stretching, and its broad side is its legible side (the
///   portraits of 1910 face the painter). With `auto`, this view is composed with both the
///   cylindrical camera (the thesis's camera for standing figures: verticals stay straight, so a
///   figure keeps its head and feet where the spherical wrap bends it into a bowl) and the
///   spherical one.
///
/// The other views are ranked on a coarse sample (`COARSE_SAMPLES` vertices, a smaller probe);
/// only the best is composed again on the full sample, as the front was, and only its candidate
/// (the same angle cap, stretch and distance). The front view stays whenever it fills, so
/// subjects facing the viewer keep facing them.
pub fn frame_camera(params: &FramingParams, world: &World, accel: &Accel) -> Result<Framed> {
    // The scene camera's view keeps the part of the subject it sees, when the view is the
    // scene camera's (not one the settings give).
    let own = params.position.is_none() && params.target.is_none();
    let view = world
        .camera
        .as_ref()
        .filter(|_| own)
        .and_then(|c| SceneView::of(c, params.width as f64 / params.height.max(1) as f64, world, accel));
    let subject = Subject::new(world, FIT_SAMPLES, COARSE_SAMPLES, view.as_ref());
    let own_view = own && world.camera.is_none();
    let (framed, fill) = first_round(params, world, accel, &subject, own_view)?;
    let _ = fill;
    Ok(framed)
}

/// The front composition and, when it fills under `FILL_FLOOR` and the view is the renderer's
/// own (`own_view`: no camera in the scene or the settings), the raised view and the broad side
/// (`frame_camera`), with the fill of the composition chosen (None: the camera was not
/// composed).
fn first_round(
    params: &FramingParams,
    world: &World,
    accel: &Accel,
    subject: &Subject,
    own_view: bool,
) -> Result<(Framed, Option<f64>)> {
    let (front, composition) = frame_view(params, world, accel, subject, View::FRONT, Search::Full)?;
    let fill = match composition {
        Some(k) if own_view && k.fill < FILL_FLOOR => k.fill,
        Some(k) => return Ok((front, Some(k.fill))),
        None => return Ok((front, None)),
    };
    let mut views = Vec::new();
    let up = params.up.map(DVec3::from).and_then(|u| u.try_normalize()).unwrap_or(DVec3::Y);
    let broad = broad_side_yaw(subject.points(true), up);
    if let Some(yaw) = broad {
        // Both faces of the broad side: a converging camera magnifies the parts nearest its
        // focal centre, behind the subject, so an arm reaching out fills less from behind.
        for yaw in [yaw, opposite(yaw)] {
            let turned = View { yaw, ..View::FRONT };
            if params.kind == CameraKind::Auto {
                views.push(View { kind: Some(CameraKind::Cylindrical), ..turned });
                views.push(View { kind: Some(CameraKind::Spherical), ..turned });
            } else {
                views.push(turned);
            }
        }
    }
    let (framed, fill) = best_view(params, world, accel, subject, &views, (front, fill))?;
    Ok((framed, Some(fill)))
}

/// The turn opposite `yaw` (the other face of the same side), within -180..180 deg.
fn opposite(yaw: f64) -> f64 {
    if yaw > 0.0 { yaw - std::f64::consts::PI } else { yaw + std::f64::consts::PI }
}

/// The fullest of `views` when it fills clearly more (by 1 / `compose::NEAR_BEST`) than
/// `current` (a camera and its fill), else `current`, with its fill. The views are ranked on the
/// coarse sample (ties: the earlier view), then only the best view's chosen candidate is
/// composed again on the full sample.
fn best_view(
    params: &FramingParams,
    world: &World,
    accel: &Accel,
    subject: &Subject,
    views: &[View],
    current: (Framed, f64),
) -> Result<(Framed, f64)> {
    let fill = current.1;
    let mut best: Option<(View, CameraKind, compose::Composition)> = None;
    for &view in views {
        let (framed, k) = frame_view(params, world, accel, subject, view, Search::Coarse)?;
        if let Some(k) = k
            && best.is_none_or(|(_, _, b)| k.fill > b.fill)
        {
            best = Some((view, framed.kind, k));
        }
    }
    let Some((view, kind, coarse)) = best else { return Ok(current) };
    if coarse.fill * compose::NEAR_BEST <= fill {
        return Ok(current);
    }
    let view = View { kind: Some(kind), ..view };
    let (other, k) = frame_view(params, world, accel, subject, view, Search::Only(coarse.candidate))?;
    Ok(match k {
        Some(k) if k.fill * compose::NEAR_BEST > fill => (other, k.fill),
        _ => current,
    })
}

/// The point level with the subject's `centre` (render space: the origin, without backdrops)
/// on the line along `forward` (a unit vector, or zero: the centroid itself) through the
/// centroid of `points`; None when it is within `CENTROID_OFFSET` (render units, the scene's
/// radius being about 1) of the centre, where it would change nothing.
fn centroid_axis(points: &[DVec3], forward: DVec3, centre: DVec3) -> Option<DVec3> {
    if points.is_empty() {
        return None;
    }
    let c = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let a = c - forward * (c - centre).dot(forward);
    (a.is_finite() && (a - centre).length() > CENTROID_OFFSET).then_some(a)
}

/// Below this distance (render units) from the scene's centre, the centroid's axis is the
/// centre's.
const CENTROID_OFFSET: f64 = 0.05;

/// The turn about `up` (radians, within -90..90 deg, counter-clockwise seen from above) that
/// faces the subject's broad side: the widest horizontal extent of `points` across the view,
/// searched in `BROAD_SIDE_STEP_DEG` steps from the front view (looking down -Z, level). None
/// when the front is already within `BROAD_SIDE_RATIO` of the widest.
fn broad_side_yaw(points: &[DVec3], up: DVec3) -> Option<f64> {
    let level = DVec3::NEG_Z.reject_from(up).try_normalize()?;
    let width = |yaw: f64| {
        let forward = level * yaw.cos() + up.cross(level) * yaw.sin();
        let right = forward.cross(up);
        let (lo, hi) = points
            .iter()
            .map(|p| p.dot(right))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
        if lo.is_finite() { hi - lo } else { 0.0 }
    };
    let steps = (180.0 / BROAD_SIDE_STEP_DEG).round() as i32;
    let (yaw, widest) = (-steps / 2..steps - steps / 2)
        .map(|i| (i as f64 * BROAD_SIDE_STEP_DEG).to_radians())
        .map(|yaw| (yaw, width(yaw)))
        .fold((0.0, f64::NEG_INFINITY), |best, c| if c.1 > best.1 { c } else { best });
    (yaw != 0.0 && widest > 0.0 && widest >= BROAD_SIDE_RATIO * width(0.0)).then_some(yaw)
}

/// `frame_camera` for one `view` (the front turned and tilted, see `View`) searched as
/// `search` says, and what `compose` chose, when it composed.
fn frame_view(
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
            None => (DVec3::NEG_Z, None),
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
                // The band is centred on the scene's vertical middle.
                let centre = c + frame.up * (0.5 * (ext_u.0 + ext_u.1) - c.dot(frame.up));
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
    Ok((Framed { camera, kind, angle_deg, view_height, focal_centre, frame, warnings }, composition))
}

/// Columns of `probe_fill`'s tiny image (rows follow the aspect).
const PROBE_COLUMNS: u32 = 48;
/// Columns of the probe when ranking views on the coarse sample.
const COARSE_PROBE_COLUMNS: u32 = 24;

/// The part of the subject nearest the focal centre a converging camera magnifies most (scale
/// about 1 / distance from C, or from the focal line): with C right behind a small part (an arm
/// behind the body, the nearest of several objects), the fullest candidate is that part blown up
/// over the canvas and the rest shrunk beside it, a "magnified ghost" that no longer reads
/// (cues stay legible). A guarded probe refuses such a candidate: when more than
/// `NEAR_C_SHARE` of the pixels showing geometry show a point within `within` of C (of the focal
/// line: `line`, its direction), it counts as filling nothing.
struct NearGuard {
    centre: DVec3,
    line: Option<DVec3>,
    within: f64,
}

/// `NearGuard`'s distance from C, in scene radii: a part this close is magnified at least 4x
/// against a subject about one radius away.
const NEAR_C_RADII: f64 = 0.25;
/// `NearGuard`'s share of the subject's pixels the magnified part may take.
const NEAR_C_SHARE: f64 = 0.5;

/// The size of a probe image `columns` wide with this aspect (width / height).
fn probe_size(aspect: f64, columns: u32) -> (u32, u32) {
    (columns, ((columns as f64 / aspect).round() as u32).clamp(8, 4 * columns))
}

/// `per_pixel` of every pixel of a tiny `w x h` image (one ray per pixel centre, row 0 on
/// top) and what its ray hits first, in pixel order; deterministic on any thread count.
fn probe<T: Send>(
    camera: &dyn Camera,
    accel: &Accel,
    (w, h): (u32, u32),
    per_pixel: impl Fn(&super::CameraRay, Option<crate::accel::Hit>) -> T + Sync,
) -> Vec<T> {
    use rayon::prelude::*;
    // The pixel centres' rays, tabulated where the camera can (`ray` bit for bit).
    let rays = camera.centre_rays(w, h);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let r = rays(i as usize, super::screen_point(x, y, glam::DVec2::splat(0.5), w, h));
            per_pixel(&r, accel.closest(r.origin, r.dir, 0.0, f32::INFINITY))
        })
        .collect()
}

/// Which pixels of a tiny `w x h` image show geometry (1) or not (0): what the canvas warp
/// is fitted to.
fn probe_coverage(camera: &dyn Camera, accel: &Accel, w: u32, h: u32) -> Vec<f64> {
    probe(camera, accel, (w, h), |_, hit| if hit.is_some() { 1.0 } else { 0.0 })
}

/// A `columns`-wide probe of `camera` at the canvas's `aspect`: 1 where a pixel centre's ray
/// hits geometry, else 0, with its width and height (the look report's stretch measure).
pub fn probe_image(camera: &dyn Camera, accel: &Accel, aspect: f64, columns: u32) -> (Vec<f64>, u32, u32) {
    let (w, h) = probe_size(aspect, columns);
    (probe_coverage(camera, accel, w, h), w, h)
}

/// The share of a tiny image (`columns` wide, one ray per pixel centre) whose rays hit
/// geometry: `compose`'s estimate of a candidate's subject fill. Deterministic (a hit count).
/// With `guard`, 0 when the guard refuses the candidate.
fn probe_fill(camera: &dyn Camera, accel: &Accel, aspect: f64, columns: u32, guard: Option<&NearGuard>) -> f64 {
    let (w, h) = probe_size(aspect, columns);
    let pixels = probe(camera, accel, (w, h), |r, hit| {
        let Some(hit) = hit else { return (0u32, 0u32) };
        let near = guard.is_some_and(|g| {
            let d = (r.origin + r.dir * hit.t).as_dvec3() - g.centre;
            let d = match g.line {
                Some(u) => d - u * d.dot(u),
                None => d,
            };
            d.length() < g.within
        });
        (1, near as u32)
    });
    let (hits, near) = pixels.iter().fold((0u32, 0u32), |a, b| (a.0 + b.0, a.1 + b.1));
    if hits > 0 && near as f64 > NEAR_C_SHARE * hits as f64 {
        return 0.0;
    }
    hits as f64 / (w * h) as f64
}

#[cfg(test)]
mod view_tests {
    use super::*;

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
        let yaw = broad_side_yaw(&board, DVec3::Y).expect("a board seen edge-on turns");
        assert!((yaw.abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{yaw}");
        // Turned by 45 deg about Y, the board's broad side is found 45 deg from the front.
        let r = glam::DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
        let turned: Vec<DVec3> = board.iter().map(|p| r * *p).collect();
        let yaw = broad_side_yaw(&turned, DVec3::Y).expect("turns");
        assert!((yaw.abs() - std::f64::consts::FRAC_PI_4).abs() < 1e-9, "{yaw}");
        // Already broad from the front, or as wide from every side (a round column): no turn.
        assert_eq!(broad_side_yaw(&boxed(DVec3::new(1.6, 1.0, 0.05), DVec3::ZERO), DVec3::Y), None);
        let column: Vec<DVec3> = (0..72)
            .flat_map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 72.0;
                [DVec3::new(a.cos(), -1.5, a.sin()), DVec3::new(a.cos(), 1.5, a.sin())]
            })
            .collect();
        assert_eq!(broad_side_yaw(&column, DVec3::Y), None);
        // A square pillar is widest across its diagonal: turned 45 deg, two faces in view.
        let pillar = broad_side_yaw(&boxed(DVec3::new(1.0, 3.0, 1.0), DVec3::ZERO), DVec3::Y).expect("turns");
        assert!((pillar.abs() - std::f64::consts::FRAC_PI_4).abs() < 1e-9, "{pillar}");
        // The up axis decides what "horizontal" is: the same board modelled z-up.
        let zup: Vec<DVec3> = board.iter().map(|p| DVec3::new(p.x, -p.z, p.y)).collect();
        assert_eq!(broad_side_yaw(&zup, DVec3::Z), None, "seen from above (-Z is the up axis): no level front");
        assert!(broad_side_yaw(&[], DVec3::Y).is_none());
    }
}

#[cfg(test)]
mod round_tests {
    use super::*;
    use crate::pipeline::Prepared;
    use crate::settings::Settings;

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
}
