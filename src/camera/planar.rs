//! The planar cubist camera (eq 4.1): rays start on a plane and converge on a focal point in
//! front of it.

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraModel, CameraRay, Projected, finish_ray};

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Planar {
    /// `frame.position` is the plane's centre c_p.
    pub frame: CameraFrame,
    /// Camera size s: the plane's height (its width is s * aspect).
    pub size: f64,
    pub aspect: f64,
    /// 1 / L where L = s cot(alpha/2) / 2 is the distance from c_p to the focal point f_p.
    /// Zero at alpha = 0: f_p at infinity, an orthographic camera.
    pub inv_focal_length: f64,
    pub clip_radius: f64,
}

impl Planar {
    /// From the convergence angle alpha (radians, in [0, pi)).
    pub fn new(frame: CameraFrame, size: f64, aspect: f64, alpha: f64, clip_radius: f64) -> Self {
        Planar { frame, size, aspect, inv_focal_length: 2.0 * (alpha / 2.0).tan() / size, clip_radius }
    }

    /// The focal point f_p, or None when it is at infinity.
    pub fn focal_point(&self) -> Option<DVec3> {
        (self.inv_focal_length > 0.0).then(|| self.frame.position + self.frame.forward / self.inv_focal_length)
    }
}

impl Camera for Planar {
    /// origin = c_p + u y s + h x s r; direction = normalize(f_p - origin). The thesis prints
    /// origin - f_p, which points away from the scene: a typo. Written as
    /// normalize(c_d - offset / L) so that alpha -> 0 (L -> infinity) tends to c_d without
    /// overflow.
    fn ray(&self, p: DVec2) -> CameraRay {
        let f = &self.frame;
        let offset = f.up * (p.y * self.size) + f.right * (p.x * self.size * self.aspect);
        let origin = f.position + offset;
        let towards = f.forward - offset * self.inv_focal_length;
        let focus = if self.inv_focal_length > 0.0 { towards.length() / self.inv_focal_length } else { f64::INFINITY };
        finish_ray(origin, towards, focus, self.clip_radius)
    }

    /// With k = 1 / L, the ray of plane offset o reaches c_p + c_d u + o (1 - u k) at parameter
    /// u along c_d - o k. So for q - c_p = c_d a + b (b across the view): u = a and
    /// o = b / (1 - a k), at depth a |c_d - o k|. Points behind the plane (a < 0) and on the
    /// focal plane away from f_p (1 - a k = 0, no ray reaches them) are seen by no ray.
    fn project(&self, q: DVec3) -> Option<Projected> {
        let f = &self.frame;
        let rel = q - f.position;
        let a = rel.dot(f.forward);
        let spread = 1.0 - a * self.inv_focal_length;
        let across = rel - f.forward * a;
        if !(a >= 0.0) {
            return None;
        }
        if spread.abs() < 1e-12 {
            // The focal plane: f_p itself is on every ray (the central one is chosen).
            let at_focus = across.length() < 1e-12 * a.max(1.0);
            return at_focus.then_some(Projected { screen: DVec2::ZERO, depth: a });
        }
        let offset = across / spread;
        let depth = a * (f.forward - offset * self.inv_focal_length).length();
        let screen = DVec2::new(offset.dot(f.right) / (self.size * self.aspect), offset.dot(f.up) / self.size);
        (screen.is_finite() && depth.is_finite()).then_some(Projected { screen, depth })
    }

    fn model(&self) -> CameraModel {
        CameraModel::Planar(self.clone())
    }
}
