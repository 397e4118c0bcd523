//! Measures of the look ("What we measure") that concern the paint. One definition,
//! shared by the tests, the paint benchmark and the look report.
//!
//! **Per-plane light**: the share of facets whose luminance varies across them by a
//! gradient, not noise, of at least 15% of the image's range. The gradient is the
//! least-squares plane L(x, y) = a + b x + c y fitted to the facet's pixels: noise and texture
//! average out of the fit, a ramp does not. Its variation across the facet is
//! sqrt(12) x the standard deviation of the fitted plane over the facet's pixels, which is
//! exactly L_max - L_min for a linear ramp over a uniform strip. Luminance is the display
//! luma (Rec. 709 weights on the sRGB-encoded 8-bit values, in [0, 1]), as a viewer sees the
//! picture; the image's range is its 99th minus its 1st luma percentile (a few stray pixels do
//! not set it). Facets under `MIN_PIXELS` pixels are left out: too small to carry a ramp.

use image::RgbaImage;

/// A facet counts when the gradient's variation across it is at least this share of the
/// image's luma range.
pub const PLANE_LIGHT_SHARE: f64 = 0.15;
/// Facets smaller than this are not counted.
pub const MIN_PIXELS: u64 = 64;

/// The display luma of every pixel of an 8-bit sRGB image, in [0, 1].
pub fn luma(img: &RgbaImage) -> Vec<f32> {
    img.pixels().map(|p| (0.2126 * p.0[0] as f32 + 0.7152 * p.0[1] as f32 + 0.0722 * p.0[2] as f32) / 255.0).collect()
}

/// The per-plane light measure of one picture.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneLightMeasure {
    /// Facets counted (at least `MIN_PIXELS` pixels).
    pub facets: usize,
    /// Of those, the facets whose gradient varies by at least `PLANE_LIGHT_SHARE` of the range.
    pub lit: usize,
    /// `lit / facets` (0 without facets).
    pub share: f64,
    /// The same share weighted by the facets' areas.
    pub area_share: f64,
    /// The image's luma range (99th - 1st percentile).
    pub range: f64,
    /// Each facet's gradient variation as a share of the range (None: too small or unused).
    pub variation: Vec<Option<f64>>,
}

/// The per-plane light measure of a picture's `luma` (row-major, `width` wide) over its facet
/// ids (`ids`, same layout).
pub fn per_plane_light(luma: &[f32], ids: &[u32], width: u32) -> PlaneLightMeasure {
    assert_eq!(luma.len(), ids.len(), "luma and facet ids differ in size");
    let w = width.max(1) as usize;
    let range = percentile_range(luma);
    let count = ids.iter().copied().max().map_or(0, |m| m as usize + 1);
    // Per facet: n, sum x, y, xx, xy, yy, L, xL, yL (coordinates relative to the image
    // centre, so the sums stay well conditioned).
    let mut s = vec![[0f64; 9]; count];
    let (cx, cy) = (w as f64 / 2.0, (luma.len() / w) as f64 / 2.0);
    for (i, (&l, &id)) in luma.iter().zip(ids).enumerate() {
        let (x, y, l) = ((i % w) as f64 + 0.5 - cx, (i / w) as f64 + 0.5 - cy, l as f64);
        let e = &mut s[id as usize];
        e[0] += 1.0;
        e[1] += x;
        e[2] += y;
        e[3] += x * x;
        e[4] += x * y;
        e[5] += y * y;
        e[6] += l;
        e[7] += x * l;
        e[8] += y * l;
    }
    let mut variation = vec![None; count];
    let (mut facets, mut lit, mut area, mut lit_area) = (0usize, 0usize, 0f64, 0f64);
    for (f, e) in s.iter().enumerate() {
        let n = e[0];
        if n < MIN_PIXELS as f64 {
            continue;
        }
        // Centred second moments; the fit's slope g solves C g = cov(p, L).
        let (mx, my, ml) = (e[1] / n, e[2] / n, e[6] / n);
        let (cxx, cxy, cyy) = (e[3] / n - mx * mx, e[4] / n - mx * my, e[5] / n - my * my);
        let (cxl, cyl) = (e[7] / n - mx * ml, e[8] / n - my * ml);
        let det = cxx * cyy - cxy * cxy;
        let fitted_var = if det > 1e-9 * (cxx * cyy).max(1e-12) {
            let gx = (cyy * cxl - cxy * cyl) / det;
            let gy = (cxx * cyl - cxy * cxl) / det;
            gx * gx * cxx + 2.0 * gx * gy * cxy + gy * gy * cyy
        } else if cxx + cyy > 0.0 {
            // A straight line of pixels: fit along it.
            let along = if cxx >= cyy { (cxl, cxx) } else { (cyl, cyy) };
            along.0 * along.0 / along.1
        } else {
            0.0
        };
        let v = (12.0 * fitted_var.max(0.0)).sqrt();
        let share = if range > 0.0 { v / range } else { 0.0 };
        variation[f] = Some(share);
        facets += 1;
        area += n;
        if share >= PLANE_LIGHT_SHARE {
            lit += 1;
            lit_area += n;
        }
    }
    PlaneLightMeasure {
        facets,
        lit,
        share: if facets > 0 { lit as f64 / facets as f64 } else { 0.0 },
        area_share: if area > 0.0 { lit_area / area } else { 0.0 },
        range,
        variation,
    }
}

/// 99th minus 1st percentile of `values` (a 4096-bin histogram over [0, 1]).
fn percentile_range(values: &[f32]) -> f64 {
    const BINS: usize = 4096;
    if values.is_empty() {
        return 0.0;
    }
    let mut h = vec![0u64; BINS];
    for &v in values {
        h[((v.clamp(0.0, 1.0) * (BINS - 1) as f32).round()) as usize] += 1;
    }
    let n = values.len() as f64;
    let at = |q: f64| {
        let mut acc = 0u64;
        for (b, &c) in h.iter().enumerate() {
            acc += c;
            if acc as f64 >= q * n {
                return b as f64 / (BINS - 1) as f64;
            }
        }
        1.0
    };
    at(0.99) - at(0.01)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::{splitmix64, unit_f64};

    fn noise(i: usize) -> f32 {
        unit_f64(splitmix64(i as u64)) as f32
    }

    #[test]
    fn a_linear_ramp_is_measured_exactly() {
        // Two facets side by side: the left a ramp from 0.2 to 0.6 across x, the right flat
        // with strong noise. The image range spans 0 .. 1 (a few pixels at each end).
        let (w, h) = (100usize, 40usize);
        let ids: Vec<u32> = (0..w * h).map(|i| (i % w >= 50) as u32).collect();
        let mut luma: Vec<f32> = (0..w * h)
            .map(|i| {
                let x = i % w;
                if x < 50 { 0.2 + 0.4 * (x as f32 + 0.5) / 50.0 } else { 0.4 + 0.3 * (noise(i) - 0.5) }
            })
            .collect();
        for k in 0..60 {
            luma[k * 37 % (w * h)] = 0.0;
            luma[(k * 53 + 11) % (w * h)] = 1.0;
        }
        let m = per_plane_light(&luma, &ids, w as u32);
        assert!((m.range - 1.0).abs() < 0.01, "{}", m.range);
        let left = m.variation[0].unwrap();
        assert!((left - 0.4).abs() < 0.03, "ramp of 0.4 measured as {left}");
        let right = m.variation[1].unwrap();
        assert!(right < 0.03, "noise is not a gradient: {right}");
        assert_eq!((m.facets, m.lit), (2, 1));
        assert_eq!(m.share, 0.5);
        assert!((m.area_share - 0.5).abs() < 1e-9);
    }

    #[test]
    fn small_facets_and_flat_images_are_not_counted() {
        let ids: Vec<u32> = (0..400u32).map(|i| if i < 10 { 1 } else { 0 }).collect();
        let m = per_plane_light(&vec![0.5; 400], &ids, 20);
        assert_eq!(m.facets, 1, "the 10-pixel facet is too small");
        assert_eq!(m.lit, 0);
        assert_eq!(m.range, 0.0);
        assert_eq!(m.variation[1], None);
    }

    #[test]
    fn a_one_pixel_wide_facet_is_fitted_along_its_line() {
        let (w, h) = (3usize, 100usize);
        let ids: Vec<u32> = (0..w * h).map(|i| (i % w == 1) as u32).collect();
        let luma: Vec<f32> = (0..w * h).map(|i| if i % w == 1 { (i / w) as f32 / 99.0 } else { 0.5 }).collect();
        let m = per_plane_light(&luma, &ids, w as u32);
        let v = m.variation[1].unwrap();
        assert!((v - 1.0).abs() < 0.1, "{v}");
    }
}
