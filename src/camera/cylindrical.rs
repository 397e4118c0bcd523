//! The cylindrical cubist camera: spherical horizontally, but rays converge on a vertical
//! focal line through the focal centre and rows map linearly to height along it, which
//! surrounds tall objects (a standing figure) better than a sphere (section 4.2).

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraModel, CameraRay, Nearest, Projected, finish_ray};

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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

    /// The row is the height of q along the focal line; the column the angle of q's horizontal
    /// offset w from the line: before the line v = w / |w| at depth d - |w|, beyond it
    /// v = -w / |w| at depth d + |w| (as the spherical camera, in the horizontal plane).
    fn project(&self, q: DVec3) -> Option<Projected> {
        let f = &self.frame;
        let rel = q - self.centre;
        let along = rel.dot(f.up);
        let y = along / self.height;
        let w = rel - f.up * along;
        let r = w.length();
        let d = self.distance;
        let Some(n) = w.try_normalize() else {
            return Some(Projected { screen: DVec2::new(0.0, y), depth: d });
        };
        let mut best = Nearest::default();
        for (v, depth) in [(n, d - r), (-n, d + r)] {
            let theta = v.dot(f.right).atan2(-v.dot(f.forward));
            best.offer(DVec2::new(theta / self.angle_x, y), depth);
        }
        best.get()
    }

    fn model(&self) -> CameraModel {
        CameraModel::Cylindrical(self.clone())
    }
}
