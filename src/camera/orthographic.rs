//! The orthographic camera: parallel rays, a baseline of Table 4.1.

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraModel, CameraRay, Projected, finish_ray};

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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

    /// Parallel rays: the point's offset across the view, at its depth along it (points behind
    /// the view plane are seen by no ray).
    fn project(&self, q: DVec3) -> Option<Projected> {
        let f = &self.frame;
        let rel = q - f.position;
        let depth = rel.dot(f.forward);
        if !(depth >= 0.0) {
            return None;
        }
        let screen = DVec2::new(rel.dot(f.right) / (self.height * self.aspect), rel.dot(f.up) / self.height);
        screen.is_finite().then_some(Projected { screen, depth })
    }

    fn model(&self) -> CameraModel {
        CameraModel::Orthographic(self.clone())
    }
}
