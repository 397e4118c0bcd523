//! Cameras turn a screen point into a ray and, for animation, a scene point back into the
//! screen point whose ray passes through it (`Camera::project`, the exact inverse of `ray`);
//! they never see the sampler, the film or the scene. One file per camera model; `moved.rs`
//! moves a camera rigidly (animation frames: orbits, animated glTF cameras); `warp.rs` remaps
//! the canvas in front of a camera so a thin subject fills it. `crate::framing` chooses their
//! parameters from the settings and the scene.
//!
//! Screen points are (x, y) in [-0.5, 0.5]^2 with (0.5, 0.5) the top-right corner.

mod cylindrical;
mod moved;
mod orthographic;
mod perspective;
mod planar;
mod spherical;
pub mod warp;

use glam::{DVec2, DVec3, Vec3};

pub use cylindrical::Cylindrical;
pub use moved::Moved;
pub use orthographic::Orthographic;
pub use perspective::Perspective;
pub use planar::Planar;
pub use spherical::Spherical;
pub use warp::Warped;

/// The camera model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CameraKind {
    /// Spherical for compact scenes, cylindrical for tall ones (`crate::framing::TALL_RATIO`).
    Auto,
    /// Rays start on a sphere and converge on the focal centre (eq 4.2).
    Spherical,
    /// Rays converge on a vertical focal line; rows map linearly to height.
    Cylindrical,
    /// Rays start on a plane and converge on a focal point (eq 4.1).
    Planar,
    /// Pinhole camera; the angle is its vertical field of view.
    Perspective,
    /// Parallel rays.
    Orthographic,
}

impl CameraKind {
    pub fn as_str(self) -> &'static str {
        match self {
            CameraKind::Auto => "auto",
            CameraKind::Spherical => "spherical",
            CameraKind::Cylindrical => "cylindrical",
            CameraKind::Planar => "planar",
            CameraKind::Perspective => "perspective",
            CameraKind::Orthographic => "orthographic",
        }
    }
}

impl std::fmt::Display for CameraKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A primary ray. `focus` is the signed distance along the ray to its focal point (where the
/// camera's rays converge); infinite for parallel rays. Re-aiming a facet (spatial
/// imprecision) moves this point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRay {
    pub origin: Vec3,
    /// Unit length.
    pub dir: Vec3,
    pub focus: f32,
    /// How far `origin` was moved forward from the camera surface (see `finish_ray`): re-aiming
    /// a facet pivots its rays on the camera surface, so it needs the original origin back.
    pub skipped: f32,
}

impl CameraRay {
    /// The ray's focal point (meaningful when `focus` is finite).
    pub fn focal_point(&self) -> Vec3 {
        self.origin + self.dir * self.focus
    }

    /// Where the ray starts on the camera surface (before clipping to the scene's sphere).
    pub fn surface_origin(&self) -> glam::DVec3 {
        self.origin.as_dvec3() - self.dir.as_dvec3() * self.skipped as f64
    }

    /// Signed distance from the camera surface to the focal point (infinite for parallel rays).
    pub fn surface_focus(&self) -> f64 {
        self.focus as f64 + self.skipped as f64
    }
}

/// A camera model: screen point -> ray, in render space, and back.
pub trait Camera: Send + Sync {
    /// The ray through screen point `p` (see the module doc for the convention).
    fn ray(&self, p: DVec2) -> CameraRay;

    /// The inverse of `ray`: the screen point whose ray passes through `q` (render space) and
    /// how far along that ray, from its origin on the camera surface, `q` lies. A point that
    /// several rays pass through (behind a converging camera's focal point, or a camera whose
    /// angle exceeds 180 degrees) gets the ray that reaches it first among those of the image,
    /// else the nearest of the others; the screen point may lie outside [-0.5, 0.5]^2 (the
    /// point is out of view). None when no ray of the camera passes through `q` (behind a
    /// pinhole or an image plane). Facets that follow the scene (`facets::motion`) carry a
    /// surface point from one frame's picture to another's with it.
    fn project(&self, q: DVec3) -> Option<Projected>;

    /// The camera as plain data, to save beside a facet layout and rebuild in another process
    /// (the frames of a render farm carry facets from the layout frame's camera).
    fn model(&self) -> CameraModel;

    /// The rays of a `width x height` image's pixel centres (`screen_point` at offset
    /// 0.5), for the traces of every pixel: (pixel index, screen point) -> `ray(p)`, bit for
    /// bit, for any point. Cameras whose rays factor into a column part and a row part
    /// tabulate those once (`grid_rays`); the others compute `ray`.
    fn centre_rays(&self, width: u32, height: u32) -> CentreRays<'_> {
        grid_centre_rays(width, height, |x| x, |y| y, |xs, ys| self.grid_rays(xs, ys), move |p| self.ray(p))
    }

    /// The rays of the grid of screen points (`xs[column]`, `ys[row]`), as (column, row) ->
    /// `ray`, bit for bit, when the camera's rays factor into a column part and a row part it
    /// can tabulate once (`Spherical`); None: compute each ray. A camera in front of another
    /// (`Warped`) tabulates its pixel centres through it.
    fn grid_rays(&self, _xs: &[f64], _ys: &[f64]) -> Option<GridRays<'_>> {
        None
    }
}

/// `Camera::grid_rays`: (column, row) -> ray.
pub type GridRays<'a> = Box<dyn Fn(usize, usize) -> CameraRay + Sync + 'a>;

/// The screen point of pixel (x, y) at sub-pixel `offset` (row 0 is the top): what the traces
/// ask `Camera::ray` for (`trace::screen_point`).
#[inline]
pub fn screen_point(x: u32, y: u32, offset: DVec2, width: u32, height: u32) -> DVec2 {
    DVec2::new((x as f64 + offset.x) / width as f64 - 0.5, 0.5 - (y as f64 + offset.y) / height as f64)
}

/// `Camera::centre_rays`: (pixel index, screen point) -> ray.
pub type CentreRays<'a> = Box<dyn Fn(usize, DVec2) -> CameraRay + Sync + 'a>;

/// Per column and per row of a `width x height` image: the centre's screen coordinate and
/// `col` / `row` of its screen point (`screen_point` at offset 0.5).
#[allow(clippy::type_complexity)]
pub(crate) fn centre_table<T>(
    width: u32,
    height: u32,
    col: impl Fn(DVec2) -> T,
    row: impl Fn(DVec2) -> T,
) -> (Vec<(u64, T)>, Vec<(u64, T)>) {
    let at = |x: u32, y: u32| screen_point(x, y, DVec2::splat(0.5), width, height);
    let cols = (0..width).map(|x| at(x, 0)).map(|p| (p.x.to_bits(), col(p))).collect();
    let rows = (0..height).map(|y| at(0, y)).map(|p| (p.y.to_bits(), row(p))).collect();
    (cols, rows)
}

/// `Camera::centre_rays` from a grid: every column's and row's centre coordinate mapped once by
/// `map_x` / `map_y` (a canvas warp; the identity for a camera's own pixels), `grid` (some
/// camera's `grid_rays`) tabulating the rays of those coordinates; a point that is not exactly
/// its pixel's centre, or every point when `grid` gives None, is `ray`'s.
pub(crate) fn grid_centre_rays<'a>(
    width: u32,
    height: u32,
    map_x: impl Fn(f64) -> f64,
    map_y: impl Fn(f64) -> f64,
    grid: impl FnOnce(&[f64], &[f64]) -> Option<GridRays<'a>>,
    ray: impl Fn(DVec2) -> CameraRay + Sync + 'a,
) -> CentreRays<'a> {
    let (cols, rows) = centre_table(width, height, |p| map_x(p.x), |p| map_y(p.y));
    let xs: Vec<f64> = cols.iter().map(|c| c.1).collect();
    let ys: Vec<f64> = rows.iter().map(|r| r.1).collect();
    let Some(grid) = grid(&xs, &ys) else { return Box::new(move |_, p| ray(p)) };
    let w = (width as usize).max(1);
    Box::new(move |i, p| {
        let (c, r) = (i % w, i / w);
        match (cols.get(c), rows.get(r)) {
            (Some(cx), Some(cy)) if cx.0 == p.x.to_bits() && cy.0 == p.y.to_bits() => grid(c, r),
            _ => ray(p),
        }
    })
}

/// Every camera as a serialisable value; it is itself a `Camera`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CameraModel {
    Spherical(Spherical),
    Cylindrical(Cylindrical),
    Planar(Planar),
    Perspective(Perspective),
    Orthographic(Orthographic),
    Moved(Box<moved::MovedModel>),
    Warped(Box<Warped>),
}

impl CameraModel {
    pub fn camera(&self) -> &dyn Camera {
        match self {
            CameraModel::Spherical(c) => c,
            CameraModel::Cylindrical(c) => c,
            CameraModel::Planar(c) => c,
            CameraModel::Perspective(c) => c,
            CameraModel::Orthographic(c) => c,
            CameraModel::Moved(c) => c.as_ref(),
            CameraModel::Warped(c) => c.as_ref(),
        }
    }
}

impl Camera for CameraModel {
    fn ray(&self, p: DVec2) -> CameraRay {
        self.camera().ray(p)
    }
    fn project(&self, q: DVec3) -> Option<Projected> {
        self.camera().project(q)
    }
    fn model(&self) -> CameraModel {
        self.clone()
    }
    fn centre_rays(&self, width: u32, height: u32) -> CentreRays<'_> {
        self.camera().centre_rays(width, height)
    }
    fn grid_rays(&self, xs: &[f64], ys: &[f64]) -> Option<GridRays<'_>> {
        self.camera().grid_rays(xs, ys)
    }
}

/// Where a camera sees a point (`Camera::project`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projected {
    pub screen: DVec2,
    /// Distance along the ray from its origin on the camera surface (`CameraRay::surface_origin`).
    pub depth: f64,
}

impl Projected {
    /// Whether the screen point lies in the image (its border included).
    pub fn in_view(&self) -> bool {
        self.screen.x.abs() <= 0.5 && self.screen.y.abs() <= 0.5
    }
}

/// Picks, among the screen points whose rays pass through a point, the one `project` returns:
/// in view before out of view, then the nearest along its ray, then the one nearest the screen's
/// centre (rays that several screen points share), then the first offered.
#[derive(Default)]
pub(crate) struct Nearest(Option<Projected>);

impl Nearest {
    pub(crate) fn offer(&mut self, screen: DVec2, depth: f64) {
        if !(depth >= 0.0 && screen.is_finite() && depth.is_finite()) {
            return;
        }
        let c = Projected { screen, depth };
        let key = |p: &Projected| (!p.in_view(), p.depth, p.screen.x.abs().max(p.screen.y.abs()));
        let better = match &self.0 {
            None => true,
            Some(b) => {
                let (kc, kb) = (key(&c), key(b));
                (!kc.0 & kb.0) || (kc.0 == kb.0 && (kc.1 < kb.1 || (kc.1 == kb.1 && kc.2 < kb.2)))
            }
        };
        if better {
            self.0 = Some(c);
        }
    }

    pub(crate) fn get(self) -> Option<Projected> {
        self.0
    }
}

/// An orthonormal camera frame: `forward` is the view direction c_d, `up` is u and
/// `right` is the horizontal direction h (the image's +x), right-handed.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CameraFrame {
    pub position: DVec3,
    pub forward: DVec3,
    pub up: DVec3,
    pub right: DVec3,
}

impl CameraFrame {
    /// Orthonormalises (forward, up). An `up` parallel to `forward` (looking straight down,
    /// say) is replaced by the world axis least aligned with `forward`; the returned flag says so.
    pub fn new(position: DVec3, forward: DVec3, up: DVec3) -> Option<(CameraFrame, bool)> {
        let f = forward.try_normalize()?;
        let mut fixed = false;
        let mut u = (up - f * up.dot(f)).try_normalize();
        if u.is_none() || up.normalize_or_zero().dot(f).abs() > 0.999_999 {
            fixed = true;
            let a = f.abs();
            let axis = if a.y <= a.x && a.y <= a.z {
                DVec3::Y
            } else if a.z <= a.x {
                DVec3::Z
            } else {
                DVec3::X
            };
            u = (axis - f * axis.dot(f)).try_normalize();
        }
        let u = u?;
        let right = f.cross(u);
        Some((CameraFrame { position, forward: f, up: u, right }, fixed))
    }
}

/// Converts the f64 ray every camera computes into a `CameraRay`, starting it where its line
/// enters the scene's bounding sphere when it would otherwise start far outside it. Nothing
/// lies outside that sphere, so hits are unchanged, and far-away origins (a planar camera at
/// ambiguity -> 0 has its focal point at infinity) keep full f32 precision.
pub(crate) fn finish_ray(origin: DVec3, dir: DVec3, focus: f64, clip_radius: f64) -> CameraRay {
    let dir = dir.try_normalize().unwrap_or(DVec3::Z);
    let (mut origin, mut focus, mut skipped) = (origin, focus, 0.0);
    let r = clip_radius;
    // The render space's scene sphere is centred at the origin.
    let b = origin.dot(dir);
    if origin.length() > 2.0 * r {
        // r^2 - (distance from the centre to the line)^2, without cancellation for far origins.
        let disc = r * r - (origin - dir * b).length_squared();
        let t_enter = if disc >= 0.0 { -b - disc.sqrt() } else { -b };
        // Stop a little outside the sphere (never past the closest approach when missing).
        let t = (t_enter - 0.01 * r).max(0.0);
        if t > 0.0 && t.is_finite() {
            origin += dir * t;
            focus -= t;
            skipped = t;
        }
    }
    let focus = if focus.is_finite() { focus.clamp(-f32::MAX as f64, f32::MAX as f64) as f32 } else { f32::INFINITY };
    CameraRay { origin: origin.as_vec3(), dir: dir.as_vec3(), focus, skipped: skipped as f32 }
}

#[cfg(test)]
mod tests;
