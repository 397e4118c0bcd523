//! The cylindrical cubist camera: spherical horizontally, but rays converge on a vertical
//! focal line through the focal centre and rows map linearly to height along it, which
//! surrounds tall objects (a standing figure) better than a sphere (section 4.2).

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraRay, finish_ray};

#[derive(Clone, Debug)]
pub struct Cylindrical {
    pub frame: CameraFrame,
    /// The focal line passes through this point along `frame.up`.
    pub centre: DVec3,
    /// Radius of the cylinder the rays start on.
    pub distance: f64,
    /// Horizontal convergence angle, radians.
    pub angle_x: f64,
    /// Length of focal line the image's height covers, render units.
    pub height: f64,
    pub clip_radius: f64,
}

impl Camera for Cylindrical {
    fn ray(&self, p: DVec2) -> CameraRay {
        let f = &self.frame;
        let (st, ct) = (p.x * self.angle_x).sin_cos();
        let v = f.right * st - f.forward * ct;
        let on_axis = self.centre + f.up * (p.y * self.height);
        finish_ray(on_axis + v * self.distance, -v, self.distance, self.clip_radius)
    }
}
