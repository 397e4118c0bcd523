//! What the framing frames:
//! - the scene without its backdrops (`scene::backdrop`: a floor or a wall much larger than the
//!   rest). Framed with its floor, a scene of objects on a 20 m plane showed them a few pixels
//!   tall on a kite of floor. The backdrop is still rendered, shaded and faceted like anything
//!   else; it only does not set the extent, the centre and the radius the cameras are composed
//!   around; nor its enclosures (`scene::enclosure`: a closed room around the camera and the
//!   furniture), which the framing would otherwise fit around the walls;
//! - of that, what the scene's own camera sees (`SceneView`), when it does not see everything: a
//!   user who framed one head in a room of statues meant the head, and the cubist camera
//!   composed around the whole room drew it a few pixels tall among the others.

use glam::{DVec2, DVec3};

use crate::accel::Accel;
use crate::camera::{Camera, CameraFrame, Orthographic, Perspective, screen_point};
use crate::scene::{Projection, SceneCamera, World};

/// Share by which a point may lie outside the scene camera's view and still count as seen
/// (a subject the user framed to the edge keeps its rim).
pub const VIEW_MARGIN: f64 = 0.05;

/// The scene camera's view, to keep the part of the subject it sees (render space): its
/// frustum, and the objects a coarse trace of its own (pinhole) picture shows.
pub struct SceneView {
    frame: CameraFrame,
    /// Perspective: the half-extents' tangents (x, y); orthographic: the half-extents.
    half: (f64, f64),
    perspective: bool,
    /// Objects the pinhole picture shows (by index, ascending).
    shown: Vec<u32>,
}

/// Columns of the trace that finds what the scene camera shows (rows follow the aspect).
const VIEW_PROBE_COLUMNS: u32 = 48;

impl SceneView {
    /// The view of `camera` on a canvas of `aspect` (width / height); None when it shows
    /// nothing of the scene.
    pub fn of(camera: &SceneCamera, aspect: f64, world: &World, accel: &Accel) -> Option<SceneView> {
        let (frame, _) = CameraFrame::new(camera.position, camera.forward, camera.up)?;
        let clip_radius = (world.radius as f64).max(1e-9) * 1.001;
        let (half, perspective, pinhole): ((f64, f64), bool, Box<dyn Camera>) = match camera.projection {
            Projection::Perspective { yfov } => {
                let t = (0.5 * yfov).tan();
                let cam = Perspective { frame, tan_half_fov: t, aspect, focus: 1.0, clip_radius };
                ((t * aspect, t), true, Box::new(cam))
            }
            Projection::Orthographic { ymag } => {
                let cam = Orthographic { frame, height: 2.0 * ymag, aspect, focus: 1.0, clip_radius };
                ((ymag * aspect, ymag), false, Box::new(cam))
            }
        };
        if !(half.0 > 0.0 && half.1 > 0.0 && half.0.is_finite() && half.1.is_finite()) {
            return None;
        }
        let columns = VIEW_PROBE_COLUMNS;
        let rows = ((columns as f64 / aspect).round() as u32).clamp(1, 4 * columns);
        let mut shown: Vec<u32> = (0..rows * columns)
            .filter_map(|i| {
                let r = pinhole.ray(screen_point(i % columns, i / columns, DVec2::splat(0.5), columns, rows));
                accel.closest(r.origin, r.dir, 0.0, f32::INFINITY).map(|h| world.object_of(h.tri))
            })
            .collect();
        shown.sort_unstable();
        shown.dedup();
        let grow = 1.0 + VIEW_MARGIN;
        (!shown.is_empty()).then_some(SceneView { frame, half: (half.0 * grow, half.1 * grow), perspective, shown })
    }

    /// Whether `p`, a point of object `object`, is in view: in front of the camera, within
    /// the margin, on an object the camera's picture shows.
    pub fn sees(&self, p: DVec3, object: u32) -> bool {
        let f = &self.frame;
        let d = p - f.position;
        let z = d.dot(f.forward);
        let scale = if self.perspective { z } else { 1.0 };
        z > 0.0
            && d.dot(f.right).abs() <= self.half.0 * scale
            && d.dot(f.up).abs() <= self.half.1 * scale
            && self.shown.binary_search(&object).is_ok()
    }
}

/// The subject's sample points, centre and radius (render space).
pub struct Subject {
    /// The centre of the subject's bounding box: the origin (the scene's centre) when there is
    /// no backdrop.
    pub centre: DVec3,
    /// The subject's bounding radius about `centre`: the scene's when there is no backdrop.
    pub radius: f64,
    /// The renderer's own view frame when the subject stands along the front view's axis
    /// (`frame_camera` sets it; None: looking down -Z, Y up).
    pub upright: Option<super::upright::Upright>,
    full: Vec<DVec3>,
    coarse: Vec<DVec3>,
}

impl Subject {
    /// The subject of `world`, with about `full` and `coarse` sample points (every n-th corner
    /// of the subject's triangles; with no backdrop or enclosure, exactly the corners a sample of
    /// the whole scene takes), kept to what `view` sees when it sees some of them but not all.
    /// With no backdrop or enclosure and everything in view, the scene's centre (the origin) and
    /// radius.
    pub fn new(world: &World, full: usize, coarse: usize, view: Option<&SceneView>) -> Subject {
        let keep: Vec<usize> = (0..world.objects.len()).filter(|&o| !world.is_setting(o)).collect();
        let (mut full, mut coarse) = (sample(world, &keep, full), sample(world, &keep, coarse));
        let mut whole = keep.len() == world.objects.len();
        if let Some(view) = view {
            let seen: Vec<(DVec3, u32)> = full.iter().copied().filter(|(p, o)| view.sees(*p, *o)).collect();
            if !seen.is_empty() && seen.len() < full.len() {
                full = seen;
                coarse.retain(|(p, o)| view.sees(*p, *o));
                if coarse.is_empty() {
                    coarse = full.iter().step_by(full.len().div_ceil(COARSE_FLOOR).max(1)).copied().collect();
                }
                whole = false;
            }
        }
        let full: Vec<DVec3> = full.into_iter().map(|(p, _)| p).collect();
        let coarse: Vec<DVec3> = coarse.into_iter().map(|(p, _)| p).collect();
        let (centre, radius) = if whole {
            (DVec3::ZERO, (world.radius as f64).max(1e-9))
        } else {
            let (lo, hi) =
                full.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
            let centre = if lo.is_finite() { (lo + hi) * 0.5 } else { DVec3::ZERO };
            let radius = full.iter().map(|p| (*p - centre).length()).fold(0.0, f64::max);
            (centre, radius.max(1e-9))
        };
        Subject { full, coarse, centre, radius, upright: None }
    }

    /// The sample points: `coarse` or full.
    pub fn points(&self, coarse: bool) -> &[DVec3] {
        if coarse { &self.coarse } else { &self.full }
    }
}

/// Fewest coarse points kept when the view leaves the coarse sample none (taken from the full
/// sample instead).
const COARSE_FLOOR: usize = 256;

/// Corners of the `objects`' triangles (a bounded sample, every n-th in triangle order) in
/// render space, each with its object; non-finite ones (never hit) skipped.
fn sample(world: &World, objects: &[usize], samples: usize) -> Vec<(DVec3, u32)> {
    let ranges: Vec<(usize, usize, u32)> = objects
        .iter()
        .map(|&o| {
            (world.objects[o].first_triangle as usize * 3, world.objects[o].triangle_count as usize * 3, o as u32)
        })
        .collect();
    let n: usize = ranges.iter().map(|r| r.1).sum();
    let step = n.div_ceil(samples).max(1);
    let mut out = Vec::with_capacity(n.div_ceil(step));
    // The k-th corner of the objects' corners laid end to end, every `step`-th.
    let (mut k, mut before) = (0, 0);
    for &(first, count, object) in &ranges {
        while k < before + count {
            let p = world.corner(first + k - before);
            if p.is_finite() {
                out.push((p.as_dvec3(), object));
            }
            k += step;
        }
        before += count;
    }
    out
}

#[cfg(test)]
mod tests {
    use glam::{DMat4, Vec3};

    use super::*;
    use crate::pipeline::Prepared;
    use crate::scene::default::ellipsoid;
    use crate::scene::{Material, Object, Scene};

    /// Balls of radius 1 at `centres` (scene units), seen by a 40 deg camera at `eye` looking
    /// down -Z.
    fn balls(centres: &[DVec3], eye: DVec3) -> Prepared {
        let mut s = Scene::default();
        s.materials.push(Material::default());
        s.meshes.push(ellipsoid("ball", Vec3::ONE, 12, 24, 0));
        for (k, &c) in centres.iter().enumerate() {
            s.objects.push(Object { name: format!("ball {k}"), mesh: 0, transform: DMat4::from_translation(c) });
        }
        s.camera = Some(SceneCamera {
            position: eye,
            forward: DVec3::NEG_Z,
            up: DVec3::Y,
            projection: Projection::Perspective { yfov: 40f64.to_radians() },
            focus_distance: None,
        });
        Prepared::new(s)
    }

    fn view(p: &Prepared) -> SceneView {
        SceneView::of(p.world.camera.as_ref().unwrap(), 4.0 / 3.0, &p.world, &p.accel).expect("a view")
    }

    #[test]
    fn a_camera_that_sees_everything_changes_nothing() {
        let p = balls(&[DVec3::new(-2.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0)], DVec3::new(0.0, 0.0, 20.0));
        let (all, seen) = (Subject::new(&p.world, 5000, 500, None), Subject::new(&p.world, 5000, 500, Some(&view(&p))));
        assert_eq!((seen.centre, seen.radius), (all.centre, all.radius));
        assert_eq!((seen.points(false), seen.points(true)), (all.points(false), all.points(true)));
        assert_eq!((all.centre, all.radius), (DVec3::ZERO, p.world.radius as f64));
    }

    /// A ball close before the camera, one hidden behind it and one far off to the side: the
    /// subject is the near ball alone.
    #[test]
    fn the_subject_is_what_the_scene_camera_shows() {
        let p =
            balls(&[DVec3::ZERO, DVec3::new(0.0, 0.0, -10.0), DVec3::new(30.0, 0.0, 0.0)], DVec3::new(0.0, 0.0, 3.0));
        let s = Subject::new(&p.world, 5000, 500, Some(&view(&p)));
        let near = p.world.to_render.point_f64(DVec3::ZERO);
        let r = p.world.to_render.length(1.0);
        assert!(!s.points(false).is_empty() && !s.points(true).is_empty());
        assert!(s.points(false).iter().chain(s.points(true)).all(|q| (*q - near).length() <= r * 1.001));
        assert!((s.centre - near).length() < 0.2 * r, "{} against {near}", s.centre);
        assert!(s.radius <= 1.001 * r && s.radius > 0.5 * r, "{} against {r}", s.radius);
        // Nothing shown: no view.
        let away = balls(&[DVec3::ZERO], DVec3::new(0.0, 0.0, -3.0));
        assert!(SceneView::of(away.world.camera.as_ref().unwrap(), 4.0 / 3.0, &away.world, &away.accel).is_none());
    }
}
