//! The spherical cubist camera (eq 4.2 and its code listing): rays start on a sphere around
//! the focal centre and point at it, so one image shows an object from many sides.

use glam::{DVec2, DVec3};

use super::{Camera, CameraFrame, CameraModel, CameraRay, GridRays, Nearest, Projected, finish_ray};

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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
    /// x * alpha_x. As in the listing, -c_d is rotated first about u by x alpha_x,
    /// then about the fixed h by y alpha_y; signs are chosen so the image's right shows the
    /// scene's right and its top the top (the listing's matrix convention is not given).
    pub fn outward(&self, p: DVec2) -> DVec3 {
        self.outward_of((p.x * self.angle_x).sin_cos(), (p.y * self.angle_y).sin_cos())
    }

    /// `outward` from the sine and cosine of x alpha_x and of y alpha_y.
    #[inline]
    fn outward_of(&self, (st, ct): (f64, f64), (sp, cp): (f64, f64)) -> DVec3 {
        let f = &self.frame;
        f.right * st + (-f.forward * cp + f.up * sp) * ct
    }

    /// The ray of `outward_of`.
    #[inline]
    fn ray_of(&self, x: (f64, f64), y: (f64, f64)) -> CameraRay {
        let v = self.outward_of(x, y);
        finish_ray(self.centre + v * self.distance, -v, self.distance, self.clip_radius)
    }

    /// The screen points whose outward vector is the unit vector `v` (the inverse of
    /// `outward`): with a = v.h, b = v.u, c = -v.c_d, sin(theta) = a, cos(theta) cos(phi) = c,
    /// cos(theta) sin(phi) = b. Two solutions, cos(theta) >= 0 and cos(theta) <= 0 (both in
    /// the image only beyond 180 degrees); atan2 keeps full precision near theta = 90 deg,
    /// where asin would not. phi is taken in (-pi, pi], the solution nearest the centre when
    /// alpha / aspect exceeds 360 degrees and several rows see the same direction.
    pub fn inverse_outward(&self, v: DVec3) -> [DVec2; 2] {
        let f = &self.frame;
        let (a, b, c) = (v.dot(f.right), v.dot(f.up), -v.dot(f.forward));
        let h = b.hypot(c);
        let screen = |theta: f64, phi: f64| DVec2::new(theta / self.angle_x, phi / self.angle_y);
        [screen(a.atan2(h), b.atan2(c)), screen(a.atan2(-h), (-b).atan2(-c))]
    }
}

impl Camera for Spherical {
    fn ray(&self, p: DVec2) -> CameraRay {
        self.ray_of((p.x * self.angle_x).sin_cos(), (p.y * self.angle_y).sin_cos())
    }

    /// A ray from C + v d along -v passes through q = C + v (d - s): before the focal centre
    /// v = (q - C) / |q - C| at depth d - |q - C| (q inside the sphere of origins), beyond it
    /// v = -(q - C) / |q - C| at depth d + |q - C|.
    fn project(&self, q: DVec3) -> Option<Projected> {
        let w = q - self.centre;
        let r = w.length();
        let d = self.distance;
        let Some(n) = w.try_normalize() else {
            // The focal centre itself: every ray passes through it; the central one is chosen.
            return Some(Projected { screen: DVec2::ZERO, depth: d });
        };
        let mut best = Nearest::default();
        for (v, depth) in [(n, d - r), (-n, d + r)] {
            for screen in self.inverse_outward(v) {
                best.offer(screen, depth);
            }
        }
        best.get()
    }

    fn model(&self) -> CameraModel {
        CameraModel::Spherical(self.clone())
    }

    /// The sines and cosines of every column's and every row's angle, once (a pixel's two
    /// `sin_cos` were a quarter of its ray's cost): the pixel centres' rays (`centre_rays`) and,
    /// through a canvas warp, the warped centres' (`Warped`).
    fn grid_rays(&self, xs: &[f64], ys: &[f64]) -> Option<GridRays<'_>> {
        let cols: Vec<(f64, f64)> = xs.iter().map(|x| (x * self.angle_x).sin_cos()).collect();
        let rows: Vec<(f64, f64)> = ys.iter().map(|y| (y * self.angle_y).sin_cos()).collect();
        Some(Box::new(move |c, r| self.ray_of(cols[c], rows[r])))
    }
}
