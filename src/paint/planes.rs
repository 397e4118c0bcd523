//! The facets seen as the painters' planes: each facet's size, centre and principal axes,
//! from its pixels alone (any facet map: polygons, segments, Voronoi cells, one facet), and
//! the side its own light comes from ("Each plane has its own light").
//!
//! Shared by the per-plane light (the ramp across each plane), chiaroscuro (the facet's
//! relit lights come from the ramp's light side), passage and brushwork (strokes run across
//! the ramp), so every effect agrees on how a plane is lit.
//!
//! The light side: painters darken a plane towards one of its long edges, so an elongated
//! facet darkens across its short axis; a roundish facet darkens away from the key light
//! (from the upper left, as the default light rig). Each facet then turns by a seeded angle
//! and a seeded share of the facets is lit from the other side, so neighbouring planes
//! disagree, as in the paintings (thesis Ch. 2: light manipulated facet by facet).

use glam::{DVec2, Vec2};
use rayon::prelude::*;

use crate::util::rng::{splitmix64, sub_seed, unit_f64};

const SALT: u64 = 0x706c_616e_6573_3031; // "planes01"
/// Where the light comes from, image coordinates (x right, y down): the upper left, as the
/// default rig's key light (`shading::LightRig`) seen from the camera.
pub const KEY: Vec2 = Vec2::new(-0.540_758_6, -0.841_179_2);
/// Largest seeded turn of a plane's light direction, degrees.
pub const MAX_TURN_DEG: f32 = 35.0;
/// Share of the planes lit from the other side.
pub const FLIPPED: f64 = 0.3;
/// Elongations between which the darkening turns from "away from the key" to "across the
/// short axis" (1 - minor / major variance: 0 round, 1 a line).
const ELONGATION: (f32, f32) = (0.25, 0.75);

/// One facet as a plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Pixel count (0: the id is not used).
    pub pixels: u64,
    /// Mean pixel centre, image coordinates.
    pub centre: Vec2,
    /// Unit direction of the largest spread of the facet's pixels.
    pub long_axis: Vec2,
    /// 1 - minor / major variance of the pixel positions: 0 round, 1 a line.
    pub elongation: f32,
    /// Unit direction (image coordinates) in which the plane darkens; its light comes from
    /// `-dark`.
    pub dark: Vec2,
    /// Lowest and highest `p . dark` over the facet's pixel centres: the ramp's two ends.
    pub span: (f32, f32),
}

impl Plane {
    /// Where pixel centre `p` lies on the plane's ramp: 0 at the light end, 1 at the dark end.
    pub fn ramp(&self, p: Vec2) -> f32 {
        let (lo, hi) = self.span;
        if hi > lo { ((p.dot(self.dark) - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 }
    }

    /// The side the plane's light comes from (unit, image coordinates).
    pub fn light_side(&self) -> Vec2 {
        -self.dark
    }
}

/// A horizontal run of one facet's pixels: row y, columns x0..x1.
#[derive(Clone, Copy)]
struct Run {
    y: u32,
    x0: u32,
    x1: u32,
    id: u32,
}

/// The runs of each row, in scan order (rows in parallel, concatenated in order).
fn runs(width: u32, ids: &[u32]) -> Vec<Run> {
    let w = width as usize;
    ids.par_chunks(w)
        .enumerate()
        .map(|(y, row)| {
            let mut out = Vec::new();
            let mut x0 = 0;
            for x in 1..=row.len() {
                if x == row.len() || row[x] != row[x0] {
                    out.push(Run { y: y as u32, x0: x0 as u32, x1: x as u32, id: row[x0] });
                    x0 = x;
                }
            }
            out
        })
        .flatten()
        .collect()
}

/// The planes of facet map `ids` (row-major, `width` wide) with `count` ids. Seeded per
/// facet: a facet's light does not depend on the other facets or on the thread count.
pub fn planes(width: u32, ids: &[u32], count: usize, seed: u64) -> Vec<Plane> {
    if width == 0 || ids.is_empty() {
        return Vec::new();
    }
    let runs = runs(width, ids);
    // Moments per facet: n, sum x, sum y, sum xx, sum xy, sum yy (pixel centres), in closed
    // form per run, summed in scan order (deterministic).
    let mut m = vec![[0f64; 6]; count];
    for r in &runs {
        let n = (r.x1 - r.x0) as f64;
        let a = r.x0 as f64 + 0.5;
        let y = r.y as f64 + 0.5;
        let sx = n * a + n * (n - 1.0) / 2.0;
        let sxx = n * a * a + a * n * (n - 1.0) + (n - 1.0) * n * (2.0 * n - 1.0) / 6.0;
        let e = &mut m[r.id as usize];
        e[0] += n;
        e[1] += sx;
        e[2] += n * y;
        e[3] += sxx;
        e[4] += sx * y;
        e[5] += n * y * y;
    }
    let seed = sub_seed(seed, SALT);
    let mut planes: Vec<Plane> = m
        .iter()
        .enumerate()
        .map(|(f, e)| {
            let n = e[0];
            if n == 0.0 {
                return Plane {
                    pixels: 0,
                    centre: Vec2::ZERO,
                    long_axis: Vec2::X,
                    elongation: 0.0,
                    dark: -KEY,
                    span: (0.0, 0.0),
                };
            }
            let c = DVec2::new(e[1] / n, e[2] / n);
            let (cxx, cxy, cyy) = (e[3] / n - c.x * c.x, e[4] / n - c.x * c.y, e[5] / n - c.y * c.y);
            // Eigen-decomposition of the 2x2 covariance.
            let tr = cxx + cyy;
            let disc = (((cxx - cyy) / 2.0).powi(2) + cxy * cxy).sqrt();
            let (l1, l2) = (tr / 2.0 + disc, (tr / 2.0 - disc).max(0.0));
            let angle = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
            let long_axis = Vec2::new(angle.cos() as f32, angle.sin() as f32);
            let elongation = if l1 > 0.0 { (1.0 - l2 / l1) as f32 } else { 0.0 };
            let h = splitmix64(seed ^ splitmix64(f as u64));
            let dark = dark_direction(long_axis, elongation, h);
            Plane { pixels: n as u64, centre: c.as_vec2(), long_axis, elongation, dark, span: (f32::MAX, f32::MIN) }
        })
        .collect();
    // The ramp's ends: the projection is linear, so each run's extremes are its end pixels.
    for r in &runs {
        let p = &mut planes[r.id as usize];
        let y = r.y as f32 + 0.5;
        for x in [r.x0 as f32 + 0.5, r.x1 as f32 - 0.5] {
            let t = Vec2::new(x, y).dot(p.dark);
            p.span = (p.span.0.min(t), p.span.1.max(t));
        }
    }
    for p in planes.iter_mut().filter(|p| p.pixels == 0) {
        p.span = (0.0, 0.0);
    }
    planes
}

/// The direction a plane darkens in (see the module doc), from its long axis, elongation and
/// its hash `h`.
pub fn dark_direction(long_axis: Vec2, elongation: f32, h: u64) -> Vec2 {
    let mut across = long_axis.perp();
    if across.dot(KEY) > 0.0 {
        across = -across;
    }
    let w = smoothstep(ELONGATION.0, ELONGATION.1, elongation);
    let base = (-KEY * (1.0 - w) + across * w).try_normalize().unwrap_or(across);
    let turn = (2.0 * unit_f64(splitmix64(h)) as f32 - 1.0) * MAX_TURN_DEG.to_radians();
    let d = Vec2::from_angle(turn).rotate(base);
    if unit_f64(splitmix64(h ^ 0x5151)) < FLIPPED { -d } else { d }
}

pub fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moments_of_a_rectangle() {
        // A 20 x 4 facet 1 inside facet 0: centre, axis along x, strongly elongated.
        let (w, h) = (30u32, 10u32);
        let ids: Vec<u32> =
            (0..w * h).map(|i| ((5..25).contains(&(i % w)) && (3..7).contains(&(i / w))) as u32).collect();
        let p = planes(w, &ids, 2, 1);
        assert_eq!(p[1].pixels, 80);
        assert!((p[1].centre - Vec2::new(15.0, 5.0)).length() < 1e-5, "{}", p[1].centre);
        assert!(p[1].long_axis.x.abs() > 0.999, "{}", p[1].long_axis);
        // Variances 399/12 and 15/12.
        assert!((p[1].elongation - (1.0 - 15.0 / 399.0)).abs() < 1e-4, "{}", p[1].elongation);
        // The span is the projection's range over the pixel centres.
        let proj: Vec<f32> = (0..w * h)
            .filter(|&i| ids[i as usize] == 1)
            .map(|i| Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5).dot(p[1].dark))
            .collect();
        let lo = proj.iter().copied().fold(f32::MAX, f32::min);
        let hi = proj.iter().copied().fold(f32::MIN, f32::max);
        assert!((p[1].span.0 - lo).abs() < 1e-4 && (p[1].span.1 - hi).abs() < 1e-4);
    }

    #[test]
    fn elongated_planes_darken_across_their_short_axis() {
        // Without the seeded turn (bounded by MAX_TURN_DEG) the direction is the short axis.
        for k in 0..200u64 {
            let axis = Vec2::from_angle(k as f32 * 0.1);
            let d = dark_direction(axis, 0.95, splitmix64(k));
            let off = d.dot(axis).abs().asin().to_degrees();
            assert!(off <= MAX_TURN_DEG + 1e-3, "{off}");
        }
        // Round planes darken away from the key (or towards it when flipped).
        let mut flipped = 0;
        for k in 0..1000u64 {
            let d = dark_direction(Vec2::X, 0.0, splitmix64(k));
            let cos = d.dot(-KEY);
            assert!(cos.abs() >= MAX_TURN_DEG.to_radians().cos() - 1e-4, "{cos}");
            flipped += (cos < 0.0) as u32;
        }
        assert!((230..370).contains(&flipped), "{flipped} of 1000 flipped");
    }

    #[test]
    fn unused_ids_and_degenerate_maps() {
        let p = planes(4, &[2, 2, 2, 2], 4, 0);
        assert_eq!(p.len(), 4);
        assert_eq!(p[0].pixels, 0);
        assert_eq!(p[2].pixels, 4);
        assert!(p[2].ramp(Vec2::new(1.5, 0.5)).is_finite());
        assert!(planes(0, &[], 0, 0).is_empty());
    }
}
