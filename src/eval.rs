//! Visible-face counting: the number of distinct triangles hit by primary rays, the measure
//! of the thesis's Table 4.1.

use serde::Serialize;

use crate::camera::CameraKind;
use crate::film::Film;
use crate::framing::Framed;
use crate::scene::World;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct VisibleFaces {
    /// Distinct triangles hit by at least one primary sample.
    pub visible: usize,
    /// Triangles in the scene (degenerate ones included, as in a mesh's face count).
    pub total: usize,
}

impl VisibleFaces {
    pub fn percent(&self) -> f64 {
        if self.total == 0 { 0.0 } else { 100.0 * self.visible as f64 / self.total as f64 }
    }
}

/// Counts the distinct triangles among every sample of a traced frame.
pub fn count_visible(film: &Film, total: usize) -> VisibleFaces {
    let mut seen = vec![false; total];
    let mut visible = 0;
    for s in &film.samples {
        if let Some(slot) = seen.get_mut(s.tri as usize)
            && !*slot
        {
            *slot = true;
            visible += 1;
        }
    }
    VisibleFaces { visible, total }
}

/// The distinct triangle ids among every sample of a traced film, ascending.
pub fn visible_ids(film: &Film, total: usize) -> Vec<u32> {
    let mut seen = vec![false; total];
    for s in &film.samples {
        if let Some(slot) = seen.get_mut(s.tri as usize) {
            *slot = true;
        }
    }
    seen.iter().enumerate().filter(|(_, s)| **s).map(|(i, _)| i as u32).collect()
}

/// The camera a count was made with, in scene units, so that an independent renderer
/// (the pyrender reference of `tests/python`) can use exactly the same one. Image axes:
/// +x = `right`, +y = `up`, view direction `forward`; pixel centres are sampled at spp 1.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CameraParams {
    pub kind: CameraKind,
    /// Convergence angle, or the perspective camera's vertical field of view, degrees;
    /// None for the orthographic camera.
    pub angle_deg: Option<f64>,
    /// Perspective: the eye. Orthographic: the centre of the view plane. Planar: the plane's
    /// centre c_p. Spherical/cylindrical: the start of the central ray.
    pub position: [f64; 3],
    pub forward: [f64; 3],
    pub up: [f64; 3],
    pub right: [f64; 3],
    /// Orthographic view height, planar plane height, cylindrical band height.
    pub view_height: Option<f64>,
    /// Where the rays converge (spherical, planar; the focal line's centre for cylindrical).
    pub focal_centre: Option<[f64; 3]>,
    /// The canvas warp in front of the camera (`camera::warp`), when the composition has one:
    /// per axis, where the camera's own evenly spaced screen coordinates -0.5 + i / n land on
    /// the canvas (x left to right, y bottom to top).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warp: Option<WarpParams>,
    pub width: u32,
    pub height: u32,
}

/// `CameraParams::warp`: the column and row maps.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WarpParams {
    pub x: crate::camera::warp::Warp,
    pub y: crate::camera::warp::Warp,
}

impl CameraParams {
    /// The camera of `framed` in `world`'s scene units, for a `width` x `height` image.
    pub fn new(framed: &Framed, world: &World, width: u32, height: u32) -> CameraParams {
        let sim = world.to_render;
        let point = |p: glam::DVec3| (p / sim.scale + sim.centre).to_array();
        let f = &framed.frame;
        CameraParams {
            kind: framed.kind,
            angle_deg: (framed.kind != CameraKind::Orthographic).then_some(framed.angle_deg),
            position: point(f.position),
            forward: f.forward.to_array(),
            up: f.up.to_array(),
            right: f.right.to_array(),
            view_height: framed.view_height.map(|h| h / sim.scale),
            focal_centre: framed.focal_centre.map(point),
            warp: framed.warped().map(|w| WarpParams { x: w.x, y: w.y }),
            width,
            height,
        }
    }
}

/// A visible-face count with the camera it was made with.
#[derive(Clone, Debug)]
pub struct Evaluation {
    pub faces: VisibleFaces,
    pub camera: CameraParams,
    /// The visible triangle ids (world ids: file order within each object, objects in order).
    pub ids: Vec<u32>,
}
