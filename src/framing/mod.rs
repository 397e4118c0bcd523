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
//! `FILL_FLOOR`, `frame_camera` also tries the subject's broad side; a subject standing along
//! the front view's axis (a z-up model) is seen from its front, upright (`upright`).

pub mod compose;
mod fit;
mod probe;
pub mod subject;
pub mod upright;
mod view;

use glam::DVec3;

pub use probe::probe_subject;
use subject::{SceneView, Subject};
use view::{Search, View, frame_view};

use crate::accel::Accel;
use crate::camera::{Camera, CameraFrame, CameraKind, CameraModel, Warped};
use crate::error::Result;
use crate::scene::World;

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
    /// Which end of a tall subject the composition crops (`compose`), if it crops one.
    pub cropped: Option<Cropped>,
}

/// The end of a tall subject a composition leaves out of the canvas.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cropped {
    /// Its foot: the band holds its top.
    Foot,
    /// Its top: the band holds its foot, where its bulk lies.
    Top,
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
        match self.cropped {
            Some(Cropped::Foot) => s += ", its foot cropped",
            Some(Cropped::Top) => s += ", its top cropped",
            None => {}
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
    let mut subject = Subject::new(world, FIT_SAMPLES, COARSE_SAMPLES, view.as_ref());
    let own_view = own && world.camera.is_none();
    if own_view && params.up.is_none() {
        subject.upright = upright::Upright::of(subject.points(false));
    }
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
    let up = params.up.map(DVec3::from).and_then(|u| u.try_normalize()).or(subject.upright.map(|u| u.up));
    let up = up.unwrap_or(DVec3::Y);
    let ahead = subject.upright.map_or(DVec3::NEG_Z, |u| u.forward);
    let broad = broad_side_yaw(subject.points(true), ahead, up);
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
/// searched in `BROAD_SIDE_STEP_DEG` steps from the front view (looking along `front`, level).
/// None when the front is already within `BROAD_SIDE_RATIO` of the widest.
fn broad_side_yaw(points: &[DVec3], front: DVec3, up: DVec3) -> Option<f64> {
    let level = front.reject_from(up).try_normalize()?;
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

#[cfg(test)]
mod tests;
