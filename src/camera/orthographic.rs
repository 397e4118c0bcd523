//! The orthographic camera: parallel rays, a baseline of Table 4.1.

use glam::DVec2;

use super::{Camera, CameraFrame, CameraRay, finish_ray};

#[derive(Clone, Debug)]
pub struct Orthographic {
    /// `frame.position` is the centre of the view plane.
    pub frame: CameraFrame,
    /// View height, render units.
    pub height: f64,
    pub aspect: f64,
    pub focus: f64,
    pub clip_radius: f64,
}

impl Camera for Orthographic {
    fn ray(&self, p: DVec2) -> CameraRay {
        let f = &self.frame;
        let origin = f.position + f.up * (p.y * self.height) + f.right * (p.x * self.height * self.aspect);
        finish_ray(origin, f.forward, self.focus, self.clip_radius)
    }
}
