//! The spherical cubist camera (eq 4.2 and its code listing): rays start on a sphere around
//! the focal centre and point at it, so one image shows an object from many sides.

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraRay, finish_ray};

#[derive(Clone, Debug)]
pub struct Spherical {
    /// Orientation (position is unused: rays are placed by `centre` and `distance`).
    pub frame: CameraFrame,
    /// Focal centre C, where every ray converges.
    pub centre: DVec3,
    /// Focal distance d: radius of the sphere the rays start on.
    pub distance: f64,
    /// Horizontal convergence angle alpha_x, radians (the ambiguity).
    pub angle_x: f64,
    /// Vertical convergence angle alpha_y, radians (the listing uses alpha / aspect).
    pub angle_y: f64,
    pub clip_radius: f64,
}

impl Spherical {
    /// The unit vector from C to the ray's origin. Eq 4.2 prints "x / alpha_x"; read as
    /// x * alpha_x (SPEC). As in the listing, -c_d is rotated first about u by x alpha_x,
    /// then about the fixed h by y alpha_y; signs are chosen so the image's right shows the
    /// scene's right and its top the top (the listing's matrix convention is not given).
    pub fn outward(&self, p: DVec2) -> DVec3 {
        let f = &self.frame;
        let (st, ct) = (p.x * self.angle_x).sin_cos();
        let (sp, cp) = (p.y * self.angle_y).sin_cos();
        f.right * st + (-f.forward * cp + f.up * sp) * ct
    }
}

impl Camera for Spherical {
    fn ray(&self, p: DVec2) -> CameraRay {
        let v = self.outward(p);
        finish_ray(self.centre + v * self.distance, -v, self.distance, self.clip_radius)
    }
}
