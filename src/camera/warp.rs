//! A canvas warp: a monotone remap of the
//! screen's columns and rows that gives those showing the subject more of the canvas and the
//! empty ones less, each within a bounded scale, so a subject whose outline fills little of
//! its bounding box (a figure with its limbs apart) still fills the canvas. `Warped` puts it in
//! front of any camera: the camera itself still only turns a screen point into a ray.
//!
//! Why a warp: a composition can only choose which lines through C the canvas shows and how
//! far it stretches them (`compose`); a stick-thin figure then fills under half its bounding
//! box from every side, and the only other way up was to magnify the part nearest C over the
//! rest. The painters did neither: Picasso's and Braque's figures of 1910 swell where the body
//! is and shrink the gaps between the limbs. The remap is separable (straight rows stay rows,
//! columns stay columns), smooth over a tenth of the canvas, and at most `strength` times
//! denser or sparser than the even spacing anywhere, so no part grows over the others.

use glam::{DVec2, DVec3};

use super::{Camera, CameraModel, CameraRay, CentreRays, Projected, grid_centre_rays};

/// Share of the axis the densities are smoothed over: the warp's scale changes gently, so
/// straight edges bend only slightly and no single row or column is singled out.
const SMOOTH_SHARE: f64 = 0.1;
/// Density of an empty row or column before the bound: it still keeps some canvas.
const EMPTY_WEIGHT: f64 = 0.02;
/// Alternations between the two axes in `fit` (each axis's occupancy is weighted by the
/// other's densities); the fill changes by under 0.1% after the third.
const PASSES: usize = 3;

/// A monotone piecewise-linear map of one screen axis onto itself, its ends fixed at -0.5 and
/// 0.5: `screen[i]` is where the camera's own coordinate -0.5 + i / n (n = `screen.len()` - 1)
/// lands on the canvas. Beyond the ends it continues with the end pieces' slopes.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "Vec<f64>", into = "Vec<f64>")]
pub struct Warp {
    screen: Vec<f64>,
}

impl TryFrom<Vec<f64>> for Warp {
    type Error = String;

    /// A warp read from a file (a farm's facet layout): at least two knots, finite, strictly
    /// increasing, from -0.5 to 0.5.
    fn try_from(screen: Vec<f64>) -> Result<Warp, String> {
        let ends = |v: f64, e: f64| (v - e).abs() <= 1e-9;
        if screen.len() < 2 || screen.len() > 1 << 16 {
            return Err(format!("a warp needs 2 to 65536 knots, not {}", screen.len()));
        }
        if !screen.iter().all(|v| v.is_finite()) || !screen.windows(2).all(|w| w[0] < w[1]) {
            return Err("a warp's knots must be finite and strictly increasing".into());
        }
        if !ends(screen[0], -0.5) || !ends(screen[screen.len() - 1], 0.5) {
            return Err("a warp's knots must run from -0.5 to 0.5".into());
        }
        Ok(Warp { screen })
    }
}

impl From<Warp> for Vec<f64> {
    fn from(w: Warp) -> Vec<f64> {
        w.screen
    }
}

impl Warp {
    /// The warp giving bin i of the camera's axis (of n equal bins) the canvas share
    /// `density[i] / n`; `density` is positive with mean 1.
    fn from_density(density: &[f64]) -> Warp {
        let n = density.len().max(1) as f64;
        let mut screen = Vec::with_capacity(density.len() + 1);
        let mut s = 0.0;
        screen.push(-0.5);
        for a in density {
            s += a;
            screen.push(s / n - 0.5);
        }
        // The sum is n up to rounding: the far end is put exactly where it belongs.
        if let Some(last) = screen.last_mut() {
            *last = 0.5;
        }
        Warp { screen }
    }

    fn bins(&self) -> usize {
        self.screen.len() - 1
    }

    /// The camera's own coordinate of canvas coordinate `s` (the inverse of `to_screen`).
    pub fn to_inner(&self, s: f64) -> f64 {
        let n = self.bins();
        let i = self.screen.partition_point(|&k| k <= s).saturating_sub(1).min(n - 1);
        let (a, b) = (self.screen[i], self.screen[i + 1]);
        -0.5 + (i as f64 + (s - a) / (b - a)) / n as f64
    }

    /// Where the camera's own coordinate `t` lands on the canvas.
    pub fn to_screen(&self, t: f64) -> f64 {
        let n = self.bins();
        let u = (t + 0.5) * n as f64;
        let i = if u.is_finite() { (u.floor().max(0.0) as usize).min(n - 1) } else { 0 };
        let (a, b) = (self.screen[i], self.screen[i + 1]);
        a + (u - i as f64) * (b - a)
    }

    /// The largest local scale of the canvas against the camera's even spacing (>= 1).
    pub fn max_scale(&self) -> f64 {
        let n = self.bins() as f64;
        self.screen.windows(2).map(|w| (w[1] - w[0]) * n).fold(1.0, f64::max)
    }
}

/// Canvas densities (mean 1) for bins with these occupancies (shares of each bin showing the
/// subject, in [0, 1]): proportional to the occupancy smoothed over `SMOOTH_SHARE` of the axis,
/// held within [1 / `strength`, `strength`].
fn density(occupancy: &[f64], strength: f64) -> Vec<f64> {
    let n = occupancy.len();
    if n == 0 {
        return Vec::new();
    }
    let half = ((n as f64 * SMOOTH_SHARE).round() as usize / 2).max(1);
    let weight: Vec<f64> = (0..n)
        .map(|i| {
            // Box filter, the ends repeated beyond the axis.
            let sum: f64 = (0..=2 * half).map(|k| occupancy[(i + k).saturating_sub(half).min(n - 1)]).sum();
            sum / (2 * half + 1) as f64 + EMPTY_WEIGHT
        })
        .collect();
    let s = strength.max(1.0);
    let mean_at = |lambda: f64| weight.iter().map(|w| (lambda * w).clamp(1.0 / s, s)).sum::<f64>() / n as f64;
    // The scale lambda whose bounded densities average 1: the mean grows with lambda from
    // 1 / s to s, so bisection (in log space) finds it.
    let (mut lo, mut hi) = (1e-9_f64, 1e9_f64);
    for _ in 0..200 {
        let mid = (lo * hi).sqrt();
        if mean_at(mid) > 1.0 { hi = mid } else { lo = mid }
    }
    let lambda = (lo * hi).sqrt();
    let d: Vec<f64> = weight.iter().map(|w| (lambda * w).clamp(1.0 / s, s)).collect();
    let mean = d.iter().sum::<f64>() / n as f64;
    d.into_iter().map(|v| v / mean).collect()
}

/// The column and row warps that give the covered cells of a `width x height` coverage image
/// (row 0 on top, values in [0, 1]) more of the canvas, each axis within `strength`. The axes
/// alternate `PASSES` times, each weighting its occupancy by the other's densities (a column
/// crossing only rows the row warp shrinks counts for less).
pub fn fit(coverage: &[f64], width: usize, height: usize, strength: f64) -> (Warp, Warp) {
    let (w, h) = (width.max(1), height.max(1));
    let at = |x: usize, y: usize| coverage.get(y * w + x).copied().unwrap_or(0.0).clamp(0.0, 1.0);
    let mut cols = vec![1.0; w];
    // Rows top first, as the image.
    let mut rows = vec![1.0; h];
    for _ in 0..PASSES {
        let occ: Vec<f64> = (0..w).map(|x| (0..h).map(|y| at(x, y) * rows[y]).sum::<f64>() / h as f64).collect();
        cols = density(&occ, strength);
        let occ: Vec<f64> = (0..h).map(|y| (0..w).map(|x| at(x, y) * cols[x]).sum::<f64>() / w as f64).collect();
        rows = density(&occ, strength);
    }
    // Screen y grows upwards: the row warp's bins run bottom first.
    rows.reverse();
    (Warp::from_density(&cols), Warp::from_density(&rows))
}

/// `inner` seen through a canvas warp: the ray of canvas point p is the inner camera's ray of
/// (`x.to_inner(p.x)`, `y.to_inner(p.y)`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Warped {
    pub inner: CameraModel,
    pub x: Warp,
    pub y: Warp,
}

impl Camera for Warped {
    fn ray(&self, p: DVec2) -> CameraRay {
        self.inner.ray(DVec2::new(self.x.to_inner(p.x), self.y.to_inner(p.y)))
    }

    fn project(&self, q: DVec3) -> Option<Projected> {
        let p = self.inner.project(q)?;
        Some(Projected { screen: DVec2::new(self.x.to_screen(p.screen.x), self.y.to_screen(p.screen.y)), ..p })
    }

    fn model(&self) -> CameraModel {
        CameraModel::Warped(Box::new(self.clone()))
    }

    /// Every column's and every row's centre mapped through the warp once, and the inner
    /// camera's rays of that grid tabulated where it can (`Camera::grid_rays`); any other
    /// point is computed as `ray`.
    fn centre_rays(&self, width: u32, height: u32) -> CentreRays<'_> {
        let (x, y) = (&self.x, &self.y);
        let grid = |xs: &[f64], ys: &[f64]| self.inner.grid_rays(xs, ys);
        grid_centre_rays(width, height, |s| x.to_inner(s), |s| y.to_inner(s), grid, move |p| self.ray(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_warp() -> Warp {
        Warp::from_density(&density(&[0.0, 0.0, 0.3, 1.0, 1.0, 0.8, 0.1, 0.0, 0.0, 0.0, 0.5, 0.2], 1.5))
    }

    #[test]
    fn densities_average_one_within_the_bound() {
        for strength in [1.0, 1.1, 1.5, 3.0] {
            let occ: Vec<f64> =
                (0..40).map(|i| if (10..18).contains(&i) { 1.0 } else { 0.05 * (i % 3) as f64 }).collect();
            let d = density(&occ, strength);
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            assert!((mean - 1.0).abs() < 1e-12, "{mean}");
            assert!(d.iter().all(|&v| v >= 1.0 / strength - 1e-9 && v <= strength + 1e-9), "{strength}: {d:?}");
            if strength > 1.0 {
                // The occupied bins get more canvas than the empty ones.
                assert!(d[14] > d[30], "{d:?}");
            }
        }
        // Even occupancy, or strength 1: the identity.
        assert!(density(&[0.3; 16], 2.0).iter().all(|&v| (v - 1.0).abs() < 1e-12));
    }

    #[test]
    fn the_maps_are_monotone_inverse_and_fix_the_ends() {
        let w = sample_warp();
        assert_eq!(w.to_screen(-0.5), -0.5);
        assert!((w.to_screen(0.5) - 0.5).abs() < 1e-15);
        assert!((w.to_inner(-0.5) + 0.5).abs() < 1e-15 && (w.to_inner(0.5) - 0.5).abs() < 1e-12);
        let mut last = f64::NEG_INFINITY;
        for k in -200..=200 {
            // Beyond the canvas too (points out of view project there).
            let t = k as f64 / 200.0 * 0.8;
            let s = w.to_screen(t);
            assert!(s > last, "not increasing at {t}");
            last = s;
            assert!((w.to_inner(s) - t).abs() < 1e-12, "{t} -> {s} -> {}", w.to_inner(s));
        }
        assert!(w.max_scale() > 1.0 && w.max_scale() <= 1.5 + 1e-9);
    }

    #[test]
    fn bad_knots_are_refused_when_read() {
        for bad in [vec![], vec![-0.5], vec![-0.5, 0.1, 0.0, 0.5], vec![-0.4, 0.5], vec![-0.5, f64::NAN, 0.5]] {
            assert!(Warp::try_from(bad.clone()).is_err(), "{bad:?}");
        }
        let w = sample_warp();
        let json = serde_json::to_string(&w).unwrap();
        assert_eq!(serde_json::from_str::<Warp>(&json).unwrap(), w);
        assert!(serde_json::from_str::<Warp>("[-0.5, 0.6, 0.2, 0.5]").is_err());
    }

    /// A thin cross in a coverage image: the warp's canvas shows it on more cells than the
    /// even spacing did, and the bound holds.
    #[test]
    fn fit_gives_the_covered_cells_more_canvas() {
        let (w, h) = (64usize, 48usize);
        let cov: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let bar = (28..36).contains(&x) && (4..44).contains(&y);
                let arm = (10..54).contains(&x) && (14..19).contains(&y);
                if bar || arm { 1.0 } else { 0.0 }
            })
            .collect();
        let before = cov.iter().sum::<f64>() / (w * h) as f64;
        let (wx, wy) = fit(&cov, w, h, 1.5);
        // Resample the coverage on the warped canvas at 4x the resolution.
        let (big_w, big_h) = (4 * w, 4 * h);
        let mut hits = 0usize;
        for y in 0..big_h {
            for x in 0..big_w {
                let sx = (x as f64 + 0.5) / big_w as f64 - 0.5;
                let sy = 0.5 - (y as f64 + 0.5) / big_h as f64;
                let (tx, ty) = (wx.to_inner(sx), wy.to_inner(sy));
                let cx = (((tx + 0.5) * w as f64) as usize).min(w - 1);
                let cy = (((0.5 - ty) * h as f64) as usize).min(h - 1);
                hits += (cov[cy * w + cx] > 0.5) as usize;
            }
        }
        let after = hits as f64 / (big_w * big_h) as f64;
        assert!(after > 1.2 * before, "{before} -> {after}");
        assert!(wx.max_scale() <= 1.5 + 1e-9 && wy.max_scale() <= 1.5 + 1e-9);
    }
}
