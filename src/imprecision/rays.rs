//! The re-aim of a facet's rays and linear facets (eq 4.6, eq
//! 4.7): from pixel positions to the rays the re-trace follows.

use glam::{DVec2, DVec3};

use crate::accel::Accel;
use crate::camera::{Camera, CameraRay, finish_ray};

/// Rays traced per facet to estimate d_ai, the mean hit distance of its re-aimed rays (eq 4.6).
pub const D_AI_SAMPLES: usize = 256;
/// Largest ray angle of a linear facet (eq 4.7's tangent is unbounded at 90 deg).
const MAX_LINEAR_ANGLE: f64 = 89.0 * std::f64::consts::PI / 180.0;

/// What the imprecision stage needs to turn pixel positions into rays and probe the scene.
pub struct AimContext<'a> {
    pub camera: &'a dyn Camera,
    pub accel: &'a Accel,
    pub width: u32,
    pub height: u32,
    /// The cameras' clip radius (see `camera::finish_ray`), for re-aimed rays.
    pub clip_radius: f64,
    /// The camera's up (render space): the axis a plane's view turns about (`views`).
    pub up: DVec3,
}

impl AimContext<'_> {
    /// Screen point of a continuous pixel position.
    pub fn screen(&self, px: DVec2) -> DVec2 {
        DVec2::new(px.x / self.width as f64 - 0.5, 0.5 - px.y / self.height as f64)
    }

    /// Continuous pixel position of a screen point.
    pub fn pixel_pos(&self, p: DVec2) -> DVec2 {
        DVec2::new((p.x + 0.5) * self.width as f64, (0.5 - p.y) * self.height as f64)
    }

    /// The camera's ray through a pixel position.
    pub fn ray_at(&self, px: DVec2) -> CameraRay {
        self.camera.ray(self.screen(px))
    }

    /// The scene point the ray hits, as a distance from its origin on the camera surface.
    fn hit_distance(&self, r: &CameraRay) -> Option<f64> {
        self.accel.closest(r.origin, r.dir, 0.0, f32::INFINITY).map(|h| h.t as f64 + r.skipped as f64)
    }

    /// The largest turn (|d_c' - d_c|) at pixel position `fc` that changes no ray: the smaller
    /// of 1e-6 and a thousandth of the angle between neighbouring pixels' rays. Why: with one
    /// focal point shared by every ray (spherical, planar cameras) a saliency centre on the
    /// background aims the facet at its own focal point (the point at the focal distance
    /// of the ray at sc), i.e. no turn at all, but the f32 rays leave a turn of ~3e-8; without
    /// this bound such facets (often the large background ones) were re-traced into the same
    /// pixels, up to 80% of the image.
    pub fn negligible_turn(&self, fc: DVec2) -> f64 {
        let a = self.ray_at(fc).dir.as_dvec3();
        let b = self.ray_at(fc + DVec2::X).dir.as_dvec3();
        ((b - a).length() * 1e-3).min(1e-6)
    }

    /// The re-aim that turns the facet-centre ray (at `fc`) towards P, the point the ray at
    /// `sc` hits (if it hits nothing: its focal point; parallel rays: its direction), and the
    /// point P itself when there is one. None when the turn is degenerate.
    pub fn reaim(&self, fc: DVec2, sc: DVec2) -> Option<(Reaim, Option<DVec3>)> {
        let c = self.ray_at(fc);
        let s = self.ray_at(sc);
        let o_c = c.surface_origin();
        let d_c = c.dir.as_dvec3();
        let (new_dir, target) = match self.accel.closest(s.origin, s.dir, 0.0, f32::INFINITY) {
            Some(h) => {
                let p = s.origin.as_dvec3() + s.dir.as_dvec3() * h.t as f64;
                ((p - o_c).try_normalize()?, Some(p))
            }
            None if s.focus.is_finite() => {
                let p = s.surface_origin() + s.dir.as_dvec3() * s.surface_focus();
                ((p - o_c).try_normalize()?, Some(p))
            }
            None => (s.dir.as_dvec3(), None),
        };
        Some((Reaim { turn: new_dir - d_c, focus: c.surface_focus() }, target))
    }

    /// The re-aim that turns the facet-centre ray (at `fc`) towards the scene point `p` (an aim
    /// carried with the scene: `carried::carry_aims`). None when the turn is degenerate.
    pub fn reaim_towards(&self, fc: DVec2, p: DVec3) -> Option<Reaim> {
        let c = self.ray_at(fc);
        let dir = (p - c.surface_origin()).try_normalize()?;
        Some(Reaim { turn: dir - c.dir.as_dvec3(), focus: c.surface_focus() })
    }

    /// The linear facet (eq 4.6) of a facet whose (re-aimed) rays have mean hit distance d_ai,
    /// estimated from up to `D_AI_SAMPLES` of its pixels. None when all of them miss: such a
    /// facet is left as it is.
    pub fn linear(&self, fc: DVec2, reaim: Option<&Reaim>, pixels: &[u32], fov_deg: f64) -> Option<Linear> {
        let w = self.width as usize;
        let m = pixels.len().min(D_AI_SAMPLES);
        let (mut sum, mut hits) = (0.0, 0usize);
        for k in 0..m {
            let i = pixels[k * pixels.len() / m] as usize;
            let px = DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let r = self.ray_at(px);
            let r = reaim.map_or(r, |a| a.apply(&r, self.clip_radius));
            if let Some(d) = self.hit_distance(&r) {
                sum += d;
                hits += 1;
            }
        }
        if hits == 0 {
            return None;
        }
        let d_ai = sum / hits as f64;
        let c = self.ray_at(fc);
        let c = reaim.map_or(c, |a| a.apply(&c, self.clip_radius));
        let dir_c = c.dir.as_dvec3();
        Some(Linear {
            d_ai,
            dir_c,
            fixed_c: c.surface_origin() + dir_c * d_ai,
            fc,
            fov_per_px: fov_deg.to_radians() / self.height as f64,
        })
    }
}

/// A facet's re-aim: the facet-centre ray's direction change and its focal distance f_c
/// (from the camera surface; infinite for parallel rays).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reaim {
    /// d_c' - d_c.
    pub turn: DVec3,
    pub focus: f64,
}

impl Reaim {
    /// The ray re-aimed at its focal point q moved by delta = f_c (d_c' - d_c): from its
    /// origin o on the camera surface, towards q + delta = o + f d + f_c (d_c' - d_c).
    /// Written as f / f_c so parallel rays (f = f_c = infinity) take the limit d + d_c' - d_c.
    pub fn apply(&self, ray: &CameraRay, clip_radius: f64) -> CameraRay {
        let (o, d, f) = (ray.surface_origin(), ray.dir.as_dvec3(), ray.surface_focus());
        let parallel = !f.is_finite() || !self.focus.is_finite() || self.focus <= 0.0 || f <= 0.0;
        let v = if parallel { d + self.turn } else { d * (f / self.focus) + self.turn };
        let Some(dir) = v.try_normalize() else { return *ray };
        let focus = if parallel { f64::INFINITY } else { v.length() * self.focus };
        finish_ray(o, dir, focus, clip_radius)
    }
}

/// A linear facet (eq 4.6, alpha from eq 4.7), in closed form. Each ray keeps its point
/// F = O + D d_ai (so the facet keeps its rendered size at the depth it shows) and takes the
/// direction D' = D_c + tan(theta) u, where D_c is the facet-centre ray, u the unit direction
/// of F - F_c across D_c, and theta = FoV |p - pc| / (y_max - y_min) (eq 4.7); O' = F - D' d_ai.
///
/// Why closed form: for a converging bundle (O = q - d_f D), eq 4.6 gives
/// D' = F - O' = d_ai D_c + (O - O(pc)) alpha / d_f, and eq 4.7's alpha makes the second term
/// d_ai tan(theta) along O - O(pc), which is parallel to F - F_c. So this is eq 4.6 + 4.7
/// for converging cameras (exactly at alpha = 0: every D' parallel, an orthographic facet), and
/// it stays defined for cameras whose rays share an origin (perspective), where O - O(pc) = 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linear {
    pub d_ai: f64,
    /// Direction of the (re-aimed) facet-centre ray.
    pub dir_c: DVec3,
    /// F_c: the facet-centre ray's point at d_ai.
    pub fixed_c: DVec3,
    /// The facet centre pc, pixels.
    pub fc: DVec2,
    /// FoV / (y_max - y_min), radians per pixel.
    pub fov_per_px: f64,
}

impl Linear {
    /// The linear ray replacing `ray` (already re-aimed) at pixel position `px`.
    pub fn apply(&self, ray: &CameraRay, px: DVec2, clip_radius: f64) -> CameraRay {
        let fixed = ray.surface_origin() + ray.dir.as_dvec3() * self.d_ai;
        let theta = (self.fov_per_px * (px - self.fc).length()).min(MAX_LINEAR_ANGLE);
        let w = fixed - self.fixed_c;
        let across = w - self.dir_c * w.dot(self.dir_c);
        let u = across.try_normalize().unwrap_or(DVec3::ZERO);
        let d = self.dir_c + u * theta.tan();
        let origin = fixed - d * self.d_ai;
        finish_ray(origin, d, d.length() * self.d_ai, clip_radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A converging bundle like the spherical camera's: origins on a sphere of radius d_f
    /// around the focal point q, pointing at it.
    fn bundle_ray(q: DVec3, d_f: f64, yaw: f64, pitch: f64) -> CameraRay {
        let out = DVec3::new(yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos());
        finish_ray(q + out * d_f, -out, d_f, 1.0e9)
    }

    #[test]
    fn reaim_sends_every_ray_of_a_converging_facet_through_the_new_focal_point() {
        let q = DVec3::new(0.1, -0.2, 0.3);
        let d_f = 4.0;
        let c = bundle_ray(q, d_f, 0.0, 0.0);
        let new_dir = DVec3::new(0.2, 0.1, -1.0).normalize();
        let reaim = Reaim { turn: new_dir - c.dir.as_dvec3(), focus: d_f };
        let q_new = c.surface_origin() + new_dir * d_f;
        for (yaw, pitch) in [(0.0, 0.0), (0.3, 0.1), (-0.4, 0.25), (0.05, -0.3)] {
            let r = bundle_ray(q, d_f, yaw, pitch);
            let a = reaim.apply(&r, 1.0e9);
            // Same origin on the camera surface, and the new focal point on the ray at its focus.
            assert!((a.surface_origin() - r.surface_origin()).length() < 1e-5);
            assert!((a.surface_origin() + a.dir.as_dvec3() * a.surface_focus() - q_new).length() < 1e-5);
        }
    }

    #[test]
    fn reaim_of_parallel_rays_turns_every_direction_without_overflow() {
        let turn = DVec3::new(0.1, 0.0, 0.0);
        let reaim = Reaim { turn, focus: f64::INFINITY };
        for x in [-1.0, 0.0, 2.0] {
            let r = finish_ray(DVec3::new(x, 0.0, 5.0), DVec3::NEG_Z, f64::INFINITY, 1.0e9);
            let a = reaim.apply(&r, 1.0e9);
            let want = (DVec3::NEG_Z + turn).normalize();
            assert!((a.dir.as_dvec3() - want).length() < 1e-6, "{:?}", a.dir);
            assert!(a.origin.is_finite() && a.focus.is_infinite());
        }
    }

    #[test]
    fn reaim_survives_clipped_origins() {
        // Far origins are clipped to the scene's sphere (radius 1 here): the re-aim pivots on
        // the camera surface anyway, so clipping changes nothing.
        let q = DVec3::ZERO;
        let (far, near) = (bundle_ray(q, 10.0, 0.2, 0.1), bundle_ray(q, 10.0, 0.2, 0.1));
        let clipped = finish_ray(far.surface_origin(), far.dir.as_dvec3(), 10.0, 1.0);
        assert!(clipped.skipped > 5.0);
        let reaim = Reaim { turn: DVec3::new(0.01, 0.02, 0.0), focus: 10.0 };
        let (a, b) = (reaim.apply(&clipped, 1.0e9), reaim.apply(&near, 1.0e9));
        assert!((a.dir - b.dir).length() < 1e-5);
        assert!((a.surface_origin() - b.surface_origin()).length() < 1e-4);
    }

    /// Eq 4.6 as printed (with O for the thesis's O' on the right-hand side).
    fn eq_4_6(o: DVec3, d: DVec3, d_ai: f64, d_f: f64, o_pc: DVec3, alpha: f64) -> (DVec3, DVec3) {
        let f = o + d * d_ai;
        let o2 = (o * (d_f - d_ai - alpha) + o_pc * (d_ai + alpha)) / d_f;
        (o2, f - o2)
    }

    #[test]
    fn linear_facets_match_eq_4_6_at_alpha_zero() {
        let (q, d_f, d_ai) = (DVec3::ZERO, 5.0, 3.2);
        let c = bundle_ray(q, d_f, 0.0, 0.0);
        let lin = Linear {
            d_ai,
            dir_c: c.dir.as_dvec3(),
            fixed_c: c.surface_origin() + c.dir.as_dvec3() * d_ai,
            fc: DVec2::new(50.0, 50.0),
            fov_per_px: 0.0,
        };
        for (yaw, pitch) in [(0.1, 0.0), (-0.2, 0.15), (0.3, -0.3)] {
            let r = bundle_ray(q, d_f, yaw, pitch);
            let (o2, d2) = eq_4_6(r.surface_origin(), r.dir.as_dvec3(), d_ai, d_f, c.surface_origin(), 0.0);
            let a = lin.apply(&r, DVec2::new(80.0, 20.0), 1.0e9);
            // Parallel to the facet-centre ray, through the same F, from eq 4.6's O'.
            assert!((a.dir.as_dvec3() - d2.normalize()).length() < 1e-6);
            assert!((a.dir.as_dvec3() - c.dir.as_dvec3()).length() < 1e-6);
            assert!((a.surface_origin() - o2).length() < 1e-5);
        }
    }

    #[test]
    fn linear_facets_follow_eq_4_7_field_of_view() {
        let (q, d_f, d_ai) = (DVec3::ZERO, 5.0, 3.2);
        let c = bundle_ray(q, d_f, 0.0, 0.0);
        let fov = 30f64.to_radians();
        let height = 600.0;
        let lin = Linear {
            d_ai,
            dir_c: c.dir.as_dvec3(),
            fixed_c: c.surface_origin() + c.dir.as_dvec3() * d_ai,
            fc: DVec2::new(300.0, 300.0),
            fov_per_px: fov / height,
        };
        // A ray 60 px right of the facet centre: eq 4.7's angle is FoV * 60 / 600 = 3 deg.
        let r = bundle_ray(q, d_f, 0.05, 0.0);
        let a = lin.apply(&r, DVec2::new(360.0, 300.0), 1.0e9);
        let angle = a.dir.as_dvec3().angle_between(c.dir.as_dvec3());
        assert!((angle - fov * 0.1).abs() < 1e-5, "{}", angle.to_degrees());
        // F is kept: the ray still passes through the point the converging ray had at d_ai.
        let f = r.surface_origin() + r.dir.as_dvec3() * d_ai;
        let o = a.surface_origin();
        let t = (f - o).dot(a.dir.as_dvec3());
        assert!((o + a.dir.as_dvec3() * t - f).length() < 1e-5);
        // And it agrees with eq 4.6 + 4.7 as printed to within the small-facet approximation.
        let o_pc = c.surface_origin();
        let alpha = d_f * d_ai * (fov * 0.1).tan() / (r.surface_origin() - o_pc).length();
        let (_, d2) = eq_4_6(r.surface_origin(), r.dir.as_dvec3(), d_ai, d_f, o_pc, alpha);
        assert!(a.dir.as_dvec3().angle_between(d2) < 2e-3, "{}", a.dir.as_dvec3().angle_between(d2));
    }

    proptest! {
        #[test]
        fn reaim_is_finite_for_any_turn_and_focus(
            tx in -1.0f64..1.0, ty in -1.0f64..1.0, focus in prop::sample::select(vec![0.5, 3.0, 1.0e6, 1.0e30, f64::INFINITY]),
            yaw in -1.0f64..1.0,
        ) {
            let r = bundle_ray(DVec3::ZERO, focus.min(1.0e30), yaw, 0.1);
            let a = Reaim { turn: DVec3::new(tx, ty, 0.0), focus }.apply(&r, 1.5);
            prop_assert!(a.origin.is_finite() && a.dir.is_finite() && !a.focus.is_nan());
            prop_assert!((a.dir.length() - 1.0).abs() < 1e-5);
        }
    }
}
