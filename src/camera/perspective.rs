//! The pinhole perspective camera: a baseline of Table 4.1.

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraModel, CameraRay, Projected, finish_ray};

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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

    /// The pinhole projection: q - eye = a (c_d + h 2x tan aspect + u 2y tan) with a its depth
    /// along the view. Points behind the eye (a <= 0) are seen by no ray.
    fn project(&self, q: DVec3) -> Option<Projected> {
        let f = &self.frame;
        let rel = q - f.position;
        let a = rel.dot(f.forward);
        if !(a > 0.0) {
            return None;
        }
        let screen = DVec2::new(
            rel.dot(f.right) / (a * 2.0 * self.tan_half_fov * self.aspect),
            rel.dot(f.up) / (a * 2.0 * self.tan_half_fov),
        );
        screen.is_finite().then_some(Projected { screen, depth: rel.length() })
    }

    fn model(&self) -> CameraModel {
        CameraModel::Perspective(self.clone())
    }
}
