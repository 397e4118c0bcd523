//! The pinhole perspective camera: a baseline of Table 4.1.

use glam::DVec2;

use super::{Camera, CameraFrame, CameraRay, finish_ray};

#[derive(Clone, Debug)]
pub struct Perspective {
    pub frame: CameraFrame,
    /// tan(vertical field of view / 2).
    pub tan_half_fov: f64,
    pub aspect: f64,
    /// Distance to the plane the rays are focused on (re-aiming pivots there).
    pub focus: f64,
    pub clip_radius: f64,
}

impl Camera for Perspective {
    fn ray(&self, p: DVec2) -> CameraRay {
        let f = &self.frame;
        let d = f.forward
            + f.right * (2.0 * p.x * self.tan_half_fov * self.aspect)
            + f.up * (2.0 * p.y * self.tan_half_fov);
        let focus = self.focus * d.length();
        finish_ray(f.position, d, focus, self.clip_radius)
    }
}
