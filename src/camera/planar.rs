//! The planar cubist camera (eq 4.1): rays start on a plane and converge on a focal point in
//! front of it.

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraRay, finish_ray};

#[derive(Clone, Debug)]
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
    /// origin - f_p, which points away from the scene: a typo (SPEC). Written as
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
}
