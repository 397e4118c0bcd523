//! Perceptual spatial imprecision (SPEC "Spatial imprecision", thesis 4.3.2): per facet, the
//! facet centre (eq 4.4), the saliency centre (eq 4.5, corrected), the discontinuity limit, and
//! the re-aim of the facet's rays at a new focal point, optionally as a size-keeping linear
//! facet (eq 4.6, alpha from eq 4.7).
//!
//! Positions are continuous pixel coordinates: pixel (x, y) covers [x, x+1) x [y, y+1), its
//! centre is (x + 0.5, y + 0.5), y grows downwards (row 0 at the top).
//!
//! The re-aim, generalised to every camera through each ray's focal point q (SPEC rule for
//! converging cameras): the facet-centre ray is turned, about its origin on the camera surface,
//! towards P, the scene point seen at the saliency centre; its focal point moves by
//! delta = f_c (d_c' - d_c). Every ray of the facet is re-aimed at its own q + delta. With
//! one shared focal point (spherical, planar) that is the SPEC's "every ray of the facet is
//! re-aimed at the new focal point"; the cylindrical camera's focal line shifts; parallel
//! rays (focus at infinity) take the limit: every direction turns by d_c' - d_c.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::accel::Accel;
use crate::camera::{Camera, CameraRay, finish_ray};
use crate::distance::squared_distance_to_features;
use crate::error::{Error, Result};
use crate::facets::{FacetMap, rand01};
use crate::settings::{FacetProjection, Imprecision, Settings};

const RANDOM_STREAM: u64 = 0x7261_6e64_6f6d;
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
    /// background aims the facet at its own focal point (SPEC: the point at the focal distance
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

    /// The linear facet (eq 4.6) of a facet whose (re-aimed) rays have mean hit distance d_ai,
    /// estimated from up to `D_AI_SAMPLES` of its pixels. None when all of them miss: such a
    /// facet is left as it is (SPEC).
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

/// What the imprecision stage decided for one facet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FacetAim {
    /// Facet centre fc (eq 4.4); None for a facet with no pixel at this size.
    pub fc: Option<DVec2>,
    /// Saliency centre (eq 4.5 with the neighbourhood), before the discontinuity limit.
    pub sc_raw: Option<DVec2>,
    /// The point the facet is aimed at: sc after the discontinuity limit, or the random point.
    pub sc: Option<DVec2>,
    /// P, the scene point seen at `sc`, when the facet was re-aimed at one.
    pub target: Option<DVec3>,
    pub reaim: Option<Reaim>,
    pub linear: Option<Linear>,
}

impl FacetAim {
    /// Whether the facet's rays differ from the pre-render's (its pixels must be re-traced).
    pub fn moved(&self) -> bool {
        self.reaim.is_some() || self.linear.is_some()
    }

    /// The facet's version of a camera ray at pixel position `px`.
    pub fn apply(&self, ray: CameraRay, px: DVec2, clip_radius: f64) -> CameraRay {
        let r = self.reaim.map_or(ray, |a| a.apply(&ray, clip_radius));
        self.linear.map_or(r, |l| l.apply(&r, px, clip_radius))
    }
}

/// Eq 4.4: the mean pixel position of each facet (None for a facet with no pixel).
pub fn facet_centres(map: &FacetMap) -> Vec<Option<DVec2>> {
    let n = map.facet_count as usize;
    let mut sum = vec![(0.0f64, 0.0f64, 0u64); n];
    let w = map.width as usize;
    for (i, &id) in map.ids.iter().enumerate() {
        let s = &mut sum[id as usize];
        s.0 += (i % w) as f64 + 0.5;
        s.1 += (i / w) as f64 + 0.5;
        s.2 += 1;
    }
    sum.iter().map(|&(x, y, c)| (c > 0).then(|| DVec2::new(x / c as f64, y / c as f64))).collect()
}

/// Eq 4.5, corrected (SPEC): the saliency-weighted mean position of each facet's pixels plus,
/// when `neighborhood` > 0, every pixel within that distance (pixels) of the facet. The
/// thesis divides by |F|, which is not a centroid; we divide by the sum of the weights. A facet
/// with no saliency keeps sc = fc.
pub fn saliency_centres(
    map: &FacetMap,
    saliency: &[f32],
    fc: &[Option<DVec2>],
    neighborhood: f64,
) -> Vec<Option<DVec2>> {
    let n = map.facet_count as usize;
    let w = map.width as usize;
    let weight = |i: usize| saliency.get(i).copied().filter(|s| s.is_finite() && *s > 0.0).unwrap_or(0.0) as f64;
    let sums: Vec<(f64, f64, f64)> = if neighborhood <= 0.0 {
        let mut sums = vec![(0.0, 0.0, 0.0); n];
        for (i, &id) in map.ids.iter().enumerate() {
            let s = weight(i);
            if s > 0.0 {
                let t = &mut sums[id as usize];
                t.0 += s * ((i % w) as f64 + 0.5);
                t.1 += s * ((i / w) as f64 + 0.5);
                t.2 += s;
            }
        }
        sums
    } else {
        let (offsets, pixels) = map.pixels_by_facet();
        (0..n)
            .into_par_iter()
            .map(|f| {
                let own = &pixels[offsets[f] as usize..offsets[f + 1] as usize];
                neighbourhood_sum(map, own, neighborhood, &weight)
            })
            .collect()
    };
    sums.iter().zip(fc).map(|(&(x, y, s), c)| c.map(|c| if s > 0.0 { DVec2::new(x / s, y / s) } else { c })).collect()
}

/// Most pixels the neighbourhood sums of `saliency_centres` may visit (about 10 s on 2 cores).
pub const NEIGHBOURHOOD_BUDGET: f64 = 1e9;

/// Pixels the neighbourhood sums visit: each facet's bounding box grown by `radius`, clipped to
/// the image. Tiny facets with a large neighbourhood cost (facets) x (image): 65536 facets
/// and 200 px at 1000 x 1000 would take an hour.
pub fn neighbourhood_work(map: &FacetMap, radius: f64) -> f64 {
    if radius <= 0.0 {
        return 0.0;
    }
    let (w, h) = (map.width as i64, map.height as i64);
    let mut boxes = vec![(i64::MAX, i64::MAX, i64::MIN, i64::MIN); map.facet_count as usize];
    for (i, &id) in map.ids.iter().enumerate() {
        let (x, y) = (i as i64 % w, i as i64 / w);
        let b = &mut boxes[id as usize];
        *b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y));
    }
    let r = radius.ceil().min((w + h) as f64) as i64;
    boxes
        .iter()
        .filter(|b| b.0 <= b.2)
        .map(|&(x0, y0, x1, y1)| {
            let bw = (x1 + r).min(w - 1) - (x0 - r).max(0) + 1;
            let bh = (y1 + r).min(h - 1) - (y0 - r).max(0) + 1;
            bw as f64 * bh as f64
        })
        .sum()
}

/// A clear error instead of an hour-long computation when the neighbourhood sums would visit
/// more than `NEIGHBOURHOOD_BUDGET` pixels. `radius` in this image's pixels.
pub fn check_neighbourhood(map: &FacetMap, radius: f64) -> Result<()> {
    let work = neighbourhood_work(map, radius);
    if work > NEIGHBOURHOOD_BUDGET {
        return Err(Error::setting(
            "neighborhood",
            format!(
                "{radius:.0} px around each of {} facets means {work:.1e} pixel visits (budget {NEIGHBOURHOOD_BUDGET:.0e}): lower the neighborhood or use fewer facets",
                map.used_facets()
            ),
        ));
    }
    Ok(())
}

/// Weighted position sums over a facet's pixels and the pixels within `radius` of them: an
/// exact Euclidean distance transform of the facet over its bounding box grown by `radius`.
fn neighbourhood_sum(map: &FacetMap, own: &[u32], radius: f64, weight: &dyn Fn(usize) -> f64) -> (f64, f64, f64) {
    if own.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    let (w, h) = (map.width as i64, map.height as i64);
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for &i in own {
        let (x, y) = (i as i64 % w, i as i64 / w);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    let r = radius.ceil() as i64;
    let (x0, y0, x1, y1) = ((x0 - r).max(0), (y0 - r).max(0), (x1 + r).min(w - 1), (y1 + r).min(h - 1));
    let (bw, bh) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let mut is_own = vec![false; bw * bh];
    for &i in own {
        let (x, y) = (i as i64 % w - x0, i as i64 / w - y0);
        is_own[y as usize * bw + x as usize] = true;
    }
    let dist = squared_distance_to_features(bw, bh, |i| is_own[i]);
    let r2 = radius * radius;
    let mut t = (0.0, 0.0, 0.0);
    for by in 0..bh {
        for bx in 0..bw {
            if dist[by * bw + bx] <= r2 {
                let (x, y) = (bx as i64 + x0, by as i64 + y0);
                let s = weight((y * w + x) as usize);
                t.0 += s * (x as f64 + 0.5);
                t.1 += s * (y as f64 + 0.5);
                t.2 += s;
            }
        }
    }
    t
}

/// The discontinuity limit: sc moved onto the circle of radius `radius` around fc when it is
/// farther than that.
pub fn limit_discontinuity(fc: DVec2, sc: DVec2, radius: f64) -> DVec2 {
    let v = sc - fc;
    let len = v.length();
    if len > radius { fc + v * (radius / len) } else { sc }
}

/// Random imprecision (User Study I's baseline): a point uniform in the disc of `radius`
/// around fc, seeded by (seed, facet).
pub fn random_centre(fc: DVec2, radius: f64, seed: u64, facet: u32) -> DVec2 {
    let r = radius * rand01(seed, RANDOM_STREAM, 2 * facet as u64).sqrt();
    let a = std::f64::consts::TAU * rand01(seed, RANDOM_STREAM, 2 * facet as u64 + 1);
    fc + DVec2::new(a.cos(), a.sin()) * r
}

/// Whether the settings make the imprecision stage change any ray: re-aiming needs a
/// discontinuity and an imprecision mode; linear facets change rays even at discontinuity 0.
pub fn changes_rays(settings: &Settings) -> bool {
    settings.facet_projection == FacetProjection::Linear
        || (settings.imprecision != Imprecision::None && settings.discontinuity > 0.0)
}

/// Decides every facet's aim: centres, the discontinuity limit (pixels at 1000 px, scaled to
/// this image), the re-aim and the linear facet. `saliency` None counts as zero saliency.
pub fn aim_facets(ctx: &AimContext, map: &FacetMap, saliency: Option<&[f32]>, settings: &Settings) -> Vec<FacetAim> {
    let scale = settings.pixel_scale();
    let radius = settings.discontinuity * scale;
    let fc = facet_centres(map);
    let sc_raw: Vec<Option<DVec2>> = match (settings.imprecision, saliency) {
        (Imprecision::Saliency, Some(s)) => saliency_centres(map, s, &fc, settings.neighborhood * scale),
        _ => fc.clone(),
    };
    let sc: Vec<Option<DVec2>> = match settings.imprecision {
        _ if radius <= 0.0 => fc.clone(),
        Imprecision::None => fc.clone(),
        Imprecision::Saliency => {
            sc_raw.iter().zip(&fc).map(|(s, c)| Some(limit_discontinuity((*c)?, (*s)?, radius))).collect()
        }
        Imprecision::Random => {
            fc.iter().enumerate().map(|(f, c)| c.map(|c| random_centre(c, radius, settings.seed, f as u32))).collect()
        }
    };
    let linear = settings.facet_projection == FacetProjection::Linear;
    let (offsets, pixels) = if linear { map.pixels_by_facet() } else { (Vec::new(), Vec::new()) };
    (0..map.facet_count as usize)
        .into_par_iter()
        .map(|f| {
            let mut aim = FacetAim { fc: fc[f], sc_raw: sc_raw[f], sc: sc[f], target: None, reaim: None, linear: None };
            let (Some(c), Some(s)) = (fc[f], sc[f]) else { return aim };
            if s != c
                && let Some((r, p)) = ctx.reaim(c, s)
            {
                if r.turn.length() > ctx.negligible_turn(c) {
                    aim.reaim = Some(r);
                }
                aim.target = p;
            }
            if linear {
                let own = &pixels[offsets[f] as usize..offsets[f + 1] as usize];
                aim.linear = ctx.linear(c, aim.reaim.as_ref(), own, settings.facet_fov);
            }
            aim
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::facets::{FacetLayout, FacetPolygon};
    use proptest::prelude::*;

    fn map_of(ids: Vec<u32>, width: u32, facet_count: u32) -> FacetMap {
        let height = ids.len() as u32 / width;
        FacetMap { width, height, ids, facet_count }
    }

    #[test]
    fn eq_4_4_facet_centre_is_the_mean_pixel_position() {
        // 4x2: facet 0 = left column pair, facet 1 = the rest, facet 2 empty.
        let m = map_of(vec![0, 1, 1, 1, 0, 1, 1, 1], 4, 3);
        let fc = facet_centres(&m);
        assert_eq!(fc[0], Some(DVec2::new(0.5, 1.0)));
        assert_eq!(fc[1], Some(DVec2::new(2.5, 1.0)));
        assert_eq!(fc[2], None);
    }

    #[test]
    fn eq_4_5_divides_by_the_weights_and_zero_saliency_keeps_fc() {
        let m = map_of(vec![0, 0, 0, 1, 1, 1], 3, 2);
        // Facet 0: saliency only on its rightmost pixel -> sc is that pixel's centre (the
        // thesis's /|F| would give a point a third of the way there). Facet 1: none.
        let s = vec![0.0, 0.0, 0.6, 0.0, 0.0, 0.0];
        let fc = facet_centres(&m);
        let sc = saliency_centres(&m, &s, &fc, 0.0);
        assert_eq!(sc[0], Some(DVec2::new(2.5, 0.5)));
        assert_eq!(sc[1], fc[1]);
        // NaN or negative saliency counts as none.
        let s = vec![f32::NAN, -1.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(saliency_centres(&m, &s, &fc, 0.0), fc);
    }

    #[test]
    fn neighbourhood_counts_pixels_outside_the_facet() {
        // 9x1: facet 0 = pixels 0..3, facet 1 = 3..9; saliency only at pixel 5.
        let m = map_of(vec![0, 0, 0, 1, 1, 1, 1, 1, 1], 9, 2);
        let mut s = vec![0.0; 9];
        s[5] = 1.0;
        let fc = facet_centres(&m);
        // Pixel 5 is 3 px from facet 0's last pixel (2): a neighbourhood of 2 misses it, 3 reaches it.
        assert_eq!(saliency_centres(&m, &s, &fc, 2.0)[0], fc[0]);
        assert_eq!(saliency_centres(&m, &s, &fc, 3.0)[0], Some(DVec2::new(5.5, 0.5)));
        assert_eq!(saliency_centres(&m, &s, &fc, 3.0)[1], Some(DVec2::new(5.5, 0.5)));
    }

    #[test]
    fn one_pixel_facets() {
        let m = map_of(vec![0, 1, 2, 3], 2, 4);
        let fc = facet_centres(&m);
        let sc = saliency_centres(&m, &[1.0, 0.0, 0.5, 1.0], &fc, 0.0);
        assert_eq!(fc[3], Some(DVec2::new(1.5, 1.5)));
        assert_eq!(sc, fc, "a one-pixel facet's saliency centre is its own centre");
    }

    #[test]
    fn facet_centre_outside_a_non_convex_facet() {
        // A ring: its centre is in the hole, owned by another facet; the centres are still
        // well defined, and the saliency centre is pulled towards the salient side.
        let ring = FacetPolygon {
            facet: 1,
            points: vec![
                [0.1, 0.1],
                [0.9, 0.1],
                [0.9, 0.9],
                [0.1, 0.9],
                [0.1, 0.1],
                [0.3, 0.3],
                [0.3, 0.7],
                [0.7, 0.7],
                [0.7, 0.3],
                [0.3, 0.3],
            ],
        };
        let l = FacetLayout { facet_count: 2, base: None, sites: vec![[0.5, 0.5]], polygons: vec![ring] };
        let m = l.rasterize(20, 20);
        let fc = facet_centres(&m);
        let c1 = fc[1].unwrap();
        assert!((c1 - DVec2::splat(10.0)).length() < 1e-9, "{c1}");
        assert_eq!(m.ids[10 * 20 + 10], 0, "the ring's centre belongs to the hole's facet");
        let s: Vec<f32> = (0..400).map(|i| if i % 20 < 5 { 1.0 } else { 0.0 }).collect();
        let sc = saliency_centres(&m, &s, &fc, 0.0)[1].unwrap();
        assert!(sc.x < 4.0 && (sc.y - 10.0).abs() < 1e-9, "{sc}");
    }

    #[test]
    fn discontinuity_limit_moves_sc_onto_the_circle() {
        let fc = DVec2::new(10.0, 10.0);
        assert_eq!(limit_discontinuity(fc, DVec2::new(13.0, 14.0), 10.0), DVec2::new(13.0, 14.0));
        let l = limit_discontinuity(fc, DVec2::new(40.0, 50.0), 10.0);
        assert!((l - DVec2::new(16.0, 18.0)).length() < 1e-12);
        assert_eq!(limit_discontinuity(fc, DVec2::new(40.0, 50.0), 0.0), fc);
    }

    #[test]
    fn random_centres_are_seeded_and_uniform_in_the_disc() {
        let fc = DVec2::new(0.0, 0.0);
        let pts: Vec<DVec2> = (0..20000).map(|f| random_centre(fc, 2.0, 9, f)).collect();
        assert!(pts.iter().all(|p| p.length() <= 2.0));
        assert_eq!(random_centre(fc, 2.0, 9, 5), pts[5]);
        assert_ne!(random_centre(fc, 2.0, 10, 5), pts[5]);
        // Uniform in area: a quarter of the points within half the radius.
        let inner = pts.iter().filter(|p| p.length() < 1.0).count() as f64 / pts.len() as f64;
        assert!((inner - 0.25).abs() < 0.02, "{inner}");
        let right = pts.iter().filter(|p| p.x > 0.0).count() as f64 / pts.len() as f64;
        assert!((right - 0.5).abs() < 0.02, "{right}");
    }

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
