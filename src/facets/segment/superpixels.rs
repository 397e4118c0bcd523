//! Superpixels: SLIC (Achanta et al. 2012) on the pre-render's colour *and* geometric buffers,
//! the over-segmentation the normalized cut then groups (it shrinks a million-pixel graph to
//! about a thousand regions, so the eigenproblem is small).
//!
//! Hand-written rather than `simple_clustering`: that crate clusters CIELAB colour only, serially,
//! while here a pixel is a vector of colour, normal, depth and saliency with object ids as a
//! hard wall, assigned in parallel with results independent of the thread count.

use glam::Vec3;
use rayon::prelude::*;

use super::SegmentWeights;
use crate::film::{Film, NO_HIT};
use crate::util::grid::Grid as PixelGrid;
use crate::util::rng::{splitmix64, unit_f64};

/// Components of a pixel's feature vector: CIELAB colour (3), normal (3), log depth, saliency.
pub const FEATURES: usize = 8;

/// Scale of each cue: a difference of one scale unit counts as 1 in the squared feature
/// distance (times the cue's weight). Chosen so that one unit is a clearly visible change.
/// CIELAB units (about 2 just-noticeable differences is 4.6; this is a distinct shade).
pub const COLOUR_SCALE: f32 = 8.0;
/// Length of a normal difference: 0.25 is about 14 degrees.
pub const NORMAL_SCALE: f32 = 0.25;
/// Relative depth change (difference of ln t): 0.05 is a 5% jump in distance.
pub const DEPTH_SCALE: f32 = 0.05;
/// Saliency (in [0, 1]) difference.
pub const SALIENCY_SCALE: f32 = 0.1;

/// SLIC's compactness m: a spatial offset of one grid interval S weighs as much as a feature
/// difference of m scale units (m = 1 keeps regions compact where the image is flat and lets
/// them follow any visible edge).
pub const COMPACTNESS: f32 = 1.0;
/// SLIC iterations (assignments); the assignment barely changes after about 4 (Achanta et al.
/// report 10 as enough for any image).
pub const SLIC_ITERATIONS: usize = 5;

/// The per-pixel features every stage of the segmentation reads, pre-scaled so that the squared
/// Euclidean distance between two feature vectors is sum_k w_k (delta_k / scale_k)^2.
pub struct Features {
    pub width: usize,
    pub height: usize,
    pub values: Vec<[f32; FEATURES]>,
    /// Object id per pixel (`NO_HIT` for the background); only read when the object weight is on.
    pub object: Vec<u32>,
    /// Raw saliency per pixel in [0, 1] (zero when the frame has none).
    pub saliency: Vec<f32>,
}

/// Cube root of t >= 0: a bit-level first guess refined by two Newton steps (relative error
/// below 1e-6, several times faster than `f32::cbrt`; a million pixels need three each).
#[inline]
fn fast_cbrt(t: f32) -> f32 {
    if t <= 0.0 {
        return 0.0;
    }
    let mut y = f32::from_bits(t.to_bits() / 3 + 709_921_077);
    y = (2.0 * y + t / (y * y)) * (1.0 / 3.0);
    y = (2.0 * y + t / (y * y)) * (1.0 / 3.0);
    y
}

/// CIELAB (D65) of a linear sRGB colour.
pub fn linear_rgb_to_lab(c: Vec3) -> [f32; 3] {
    let c = c.max(Vec3::ZERO);
    let x = 0.4124564 * c.x + 0.3575761 * c.y + 0.1804375 * c.z;
    let y = 0.2126729 * c.x + 0.7151522 * c.y + 0.0721750 * c.z;
    let z = 0.0193339 * c.x + 0.119192 * c.y + 0.9503041 * c.z;
    let f = |t: f32| if t > 216.0 / 24389.0 { fast_cbrt(t) } else { (24389.0 / 27.0 * t + 16.0) / 116.0 };
    let (fx, fy, fz) = (f(x / 0.95047), f(y), f(z / 1.08883));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

impl Features {
    /// Reads colour, normal, depth, object and saliency off the pre-render. Background pixels
    /// get a zero normal and a depth beyond the farthest hit, so they differ from every surface.
    pub fn new(film: &Film, weights: &SegmentWeights) -> Features {
        let (width, height) = (film.width as usize, film.height as usize);
        let n = width * height;
        let far = film.hits.iter().filter(|h| h.is_hit() && h.t.is_finite()).fold(1e-6f32, |m, h| m.max(h.t));
        let far_ln = far.ln() + std::f32::consts::LN_2;
        let saliency: Vec<f32> = match &film.saliency {
            Some(s) => s.iter().map(|v| if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 }).collect(),
            None => vec![0.0; n],
        };
        let kc = weights.colour.max(0.0).sqrt() / COLOUR_SCALE;
        let kn = weights.normal.max(0.0).sqrt() / NORMAL_SCALE;
        let kd = weights.depth.max(0.0).sqrt() / DEPTH_SCALE;
        let ks = weights.saliency.max(0.0).sqrt() / SALIENCY_SCALE;
        let values: Vec<[f32; FEATURES]> = (0..n)
            .into_par_iter()
            .map(|i| {
                let lab = linear_rgb_to_lab(film.color[i].truncate());
                let h = &film.hits[i];
                let (normal, depth) =
                    if h.is_hit() && h.t.is_finite() { (h.normal, h.t.max(1e-6).ln()) } else { (Vec3::ZERO, far_ln) };
                [
                    lab[0] * kc,
                    lab[1] * kc,
                    lab[2] * kc,
                    normal.x * kn,
                    normal.y * kn,
                    normal.z * kn,
                    depth * kd,
                    saliency[i] * ks,
                ]
            })
            .collect();
        let object = film.hits.iter().map(|h| if h.is_hit() { h.object } else { NO_HIT }).collect();
        Features { width, height, values, object, saliency }
    }
}

/// Squared distance between two pre-scaled feature vectors.
#[inline]
pub fn feature_distance(a: &[f32; FEATURES], b: &[f32; FEATURES]) -> f32 {
    let mut d = 0.0;
    for k in 0..FEATURES {
        let t = a[k] - b[k];
        d += t * t;
    }
    d
}

/// A superpixel label per pixel, labels 0..count numbered in scan order of their first pixel;
/// every superpixel is 4-connected and, when objects separate, lies on one object.
#[derive(Clone, Debug)]
pub struct Superpixels {
    pub width: usize,
    pub height: usize,
    pub labels: Vec<u32>,
    pub count: usize,
}

#[derive(Clone, Copy)]
struct Centre {
    x: f32,
    y: f32,
    f: [f32; FEATURES],
    object: u32,
}

/// The grid of SLIC seeds: `gx` x `gy` cells, cell (i, j) spanning
/// [i W / gx, (i+1) W / gx) x [j H / gy, (j+1) H / gy).
struct Grid {
    gx: usize,
    gy: usize,
    width: usize,
    height: usize,
}

impl Grid {
    fn new(width: usize, height: usize, count: usize) -> Grid {
        let s = ((width * height) as f64 / count.max(1) as f64).sqrt();
        let gx = ((width as f64 / s).round() as usize).clamp(1, width);
        let gy = ((height as f64 / s).round() as usize).clamp(1, height);
        Grid { gx, gy, width, height }
    }
    fn x0(&self, i: usize) -> usize {
        i * self.width / self.gx
    }
    fn y0(&self, j: usize) -> usize {
        j * self.height / self.gy
    }
    /// Mean cell side, pixels (SLIC's S).
    fn interval(&self) -> f32 {
        ((self.width * self.height) as f32 / (self.gx * self.gy) as f32).sqrt()
    }
}

/// SLIC superpixels, about `count` of them (the grid decides the exact seed count), then
/// connectivity enforcement. `separate_objects`: a pixel only joins a seed on its own object
/// and the final superpixels are split along object boundaries.
///
/// Each pixel compares the seeds of the 3 x 3 grid cells around its own (the 2S x 2S search
/// window of SLIC, seen from the pixel as in gSLICr), so rows are assigned in parallel; the
/// seed update sums each seed's pixels in a fixed order, so the result does not depend on
/// the thread count.
pub fn slic(features: &Features, count: usize, separate_objects: bool, seed: u64) -> Superpixels {
    let (w, h) = (features.width, features.height);
    let grid = Grid::new(w, h, count);
    let s = grid.interval();
    let spatial = (COMPACTNESS / s) * (COMPACTNESS / s);
    let f = &features.values;
    let obj = &features.object;

    // Seeds: cell centres jittered by up to S/4 (seeded) so superpixels in flat regions are
    // irregular polygons rather than a square grid (segment boundaries through a flat
    // background would otherwise be staircases), then moved to the lowest-gradient pixel of
    // their 3 x 3 neighbourhood.
    let gradient = |x: usize, y: usize| -> f32 {
        let xl = x.saturating_sub(1);
        let xr = (x + 1).min(w - 1);
        let yt = y.saturating_sub(1);
        let yb = (y + 1).min(h - 1);
        feature_distance(&f[y * w + xl], &f[y * w + xr]) + feature_distance(&f[yt * w + x], &f[yb * w + x])
    };
    let mut centres: Vec<Centre> = (0..grid.gx * grid.gy)
        .map(|c| {
            let (i, j) = (c % grid.gx, c / grid.gx);
            let h1 = splitmix64(seed ^ splitmix64(c as u64));
            let jitter = |h: u64, lo: usize, hi: usize| -> usize {
                let (lo, hi) = (lo as f64, hi as f64);
                let mid = 0.5 * (lo + hi) + (unit_f64(h) - 0.5) * 0.5 * (hi - lo);
                (mid as usize).clamp(lo as usize, (hi as usize).saturating_sub(1).max(lo as usize))
            };
            let cx = jitter(h1, grid.x0(i), grid.x0(i + 1));
            let cy = jitter(splitmix64(h1), grid.y0(j), grid.y0(j + 1));
            let (mut best, mut bx, mut by) = (f32::INFINITY, cx, cy);
            for y in cy.saturating_sub(1)..=(cy + 1).min(h - 1) {
                for x in cx.saturating_sub(1)..=(cx + 1).min(w - 1) {
                    let g = gradient(x, y);
                    if g < best {
                        (best, bx, by) = (g, x, y);
                    }
                }
            }
            let p = by * w + bx;
            Centre { x: bx as f32, y: by as f32, f: f[p], object: obj[p] }
        })
        .collect();

    let mut labels = vec![0u32; w * h];
    for iteration in 0..SLIC_ITERATIONS {
        assign(&mut labels, features, &grid, &centres, spatial, separate_objects);
        if iteration + 1 == SLIC_ITERATIONS {
            break;
        }
        centres = update(&labels, features, &grid, &centres);
    }
    let mut sp = Superpixels { width: w, height: h, labels, count: centres.len() };
    enforce_connectivity(&mut sp, features, separate_objects, (s * s / 8.0).max(1.0) as usize);
    sp
}

fn assign(
    labels: &mut [u32],
    features: &Features,
    grid: &Grid,
    centres: &[Centre],
    spatial: f32,
    separate_objects: bool,
) {
    let w = features.width;
    // Per column: its cell and the neighbouring cell on the side of the column (left of the
    // cell's middle: the cell to the left). Seeds stay near their cell's middle, so the seeds
    // within reach (SLIC's window: S around the seed) are those of these 2 x 2 cells.
    let near = |pos: usize, cells: usize, size: usize, start: &dyn Fn(usize) -> usize| -> (usize, usize) {
        let c = (pos * cells / size).min(cells - 1);
        let mid2 = start(c) + start(c + 1);
        let other = if 2 * pos < mid2 { c.checked_sub(1) } else { Some(c + 1).filter(|&o| o < cells) };
        (c, other.unwrap_or(c))
    };
    let columns: Vec<(usize, usize)> = (0..w).map(|x| near(x, grid.gx, grid.width, &|i| grid.x0(i))).collect();
    labels.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let (cy, oy) = near(y, grid.gy, grid.height, &|j| grid.y0(j));
        let yf = y as f32;
        for (x, label) in row.iter_mut().enumerate() {
            let (cx, ox) = columns[x];
            let p = y * w + x;
            let fp = &features.values[p];
            let op = features.object[p];
            let xf = x as f32;
            // The pixel's own cell's seed unless a nearer one is found: a distance that
            // overflows to infinity or NaN never leaves a label outside this pixel's band.
            let own = cy * grid.gx + cx;
            let (mut best, mut best_d) = (own as u32, f32::INFINITY);
            for c in [own, cy * grid.gx + ox, oy * grid.gx + cx, oy * grid.gx + ox] {
                let ce = &centres[c];
                let (dx, dy) = (xf - ce.x, yf - ce.y);
                let mut d = feature_distance(fp, &ce.f) + spatial * (dx * dx + dy * dy);
                if separate_objects && ce.object != op {
                    // Another object's seed is only taken when no seed of this object is near;
                    // connectivity enforcement then splits it off.
                    d += 1e12;
                }
                if d < best_d {
                    (best, best_d) = (c as u32, d);
                }
            }
            *label = best;
        }
    });
}

/// Each seed moves to the mean position and features of its pixels; its object becomes that
/// of the pixel at its new position when that pixel is its own. Sums run per band of grid
/// rows (pixels of band j belong to seeds of grid rows j-1..j+1) in parallel, then are added
/// band by band in order: the same bits on any thread count.
fn update(labels: &[u32], features: &Features, grid: &Grid, centres: &[Centre]) -> Vec<Centre> {
    let w = features.width;
    type Acc = (u64, f64, f64, [f64; FEATURES]);
    let bands: Vec<(usize, Vec<Acc>)> = (0..grid.gy)
        .into_par_iter()
        .map(|j| {
            let first = j.saturating_sub(1) * grid.gx;
            let rows = ((j + 2).min(grid.gy) - j.saturating_sub(1)) * grid.gx;
            let mut acc: Vec<Acc> = vec![(0, 0.0, 0.0, [0.0; FEATURES]); rows];
            for y in grid.y0(j)..grid.y0(j + 1) {
                for x in 0..w {
                    let p = y * w + x;
                    let a = &mut acc[labels[p] as usize - first];
                    a.0 += 1;
                    a.1 += x as f64;
                    a.2 += y as f64;
                    let fp = &features.values[p];
                    for k in 0..FEATURES {
                        a.3[k] += fp[k] as f64;
                    }
                }
            }
            (first, acc)
        })
        .collect();
    let mut total: Vec<Acc> = vec![(0, 0.0, 0.0, [0.0; FEATURES]); centres.len()];
    for (first, acc) in bands {
        for (i, a) in acc.iter().enumerate() {
            let t = &mut total[first + i];
            t.0 += a.0;
            t.1 += a.1;
            t.2 += a.2;
            for k in 0..FEATURES {
                t.3[k] += a.3[k];
            }
        }
    }
    total
        .iter()
        .enumerate()
        .map(|(c, &(n, sx, sy, sf))| {
            if n == 0 {
                return centres[c];
            }
            let inv = 1.0 / n as f64;
            let (x, y) = (sx * inv, sy * inv);
            let px = (x.round() as usize).min(w - 1);
            let py = (y.round() as usize).min(features.height - 1);
            let mut f = [0f32; FEATURES];
            for k in 0..FEATURES {
                f[k] = (sf[k] * inv) as f32;
            }
            let p = py * w + px;
            let object = if labels[p] as usize == c { features.object[p] } else { centres[c].object };
            Centre { x: x as f32, y: y as f32, f, object }
        })
        .collect()
}

/// Union-find with path halving.
pub(crate) struct Dsu {
    parent: Vec<u32>,
}

impl Dsu {
    pub(crate) fn new(n: usize) -> Dsu {
        Dsu { parent: (0..n as u32).collect() }
    }
    pub(crate) fn find(&mut self, mut a: u32) -> u32 {
        while self.parent[a as usize] != a {
            let g = self.parent[self.parent[a as usize] as usize];
            self.parent[a as usize] = g;
            a = g;
        }
        a
    }
    /// Joins two sets; the smaller root index becomes the root (deterministic).
    pub(crate) fn union(&mut self, a: u32, b: u32) -> u32 {
        let (ra, rb) = (self.find(a), self.find(b));
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        self.parent[hi as usize] = lo;
        lo
    }
}

/// Makes every superpixel one 4-connected piece (and one object when `separate_objects`):
/// pieces of at least `min_area` pixels become superpixels of their own, smaller ones join the
/// neighbouring piece (of the same object) they share the longest boundary with. Labels are
/// renumbered 0.. in scan order.
pub fn enforce_connectivity(sp: &mut Superpixels, features: &Features, separate_objects: bool, min_area: usize) {
    let (w, h) = (sp.width, sp.height);
    let n = w * h;
    let same = |p: usize, q: usize| -> bool {
        sp.labels[p] == sp.labels[q] && (!separate_objects || features.object[p] == features.object[q])
    };
    // Connected pieces, by union-find over right and down neighbours.
    let mut dsu = Dsu::new(n);
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            if x + 1 < w && same(p, p + 1) {
                dsu.union(p as u32, (p + 1) as u32);
            }
            if y + 1 < h && same(p, p + w) {
                dsu.union(p as u32, (p + w) as u32);
            }
        }
    }
    // Piece index per pixel, in scan order of first pixel (roots are the smallest index).
    let mut piece = vec![u32::MAX; n];
    let mut pieces = 0u32;
    let mut root_piece = vec![u32::MAX; n];
    for p in 0..n {
        let r = dsu.find(p as u32) as usize;
        if root_piece[r] == u32::MAX {
            root_piece[r] = pieces;
            pieces += 1;
        }
        piece[p] = root_piece[r];
    }
    drop(root_piece);
    let m = pieces as usize;
    let mut area = vec![0usize; m];
    let mut piece_object = vec![NO_HIT; m];
    for p in 0..n {
        area[piece[p] as usize] += 1;
        piece_object[piece[p] as usize] = features.object[p];
    }
    // Shared boundary lengths between pieces where at least one is small.
    let small = |a: u32| area[a as usize] < min_area;
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    let grid = PixelGrid { width: w, height: h };
    for p in 0..n {
        let a = piece[p];
        for q in grid.forward_neighbours(p) {
            let b = piece[q];
            if a != b && (small(a) || small(b)) {
                pairs.push((a, b));
                pairs.push((b, a));
            }
        }
    }
    pairs.sort_unstable();
    // Smallest pieces first; each joins its longest-boundary neighbour (same object if required).
    let mut order: Vec<u32> = (0..pieces).filter(|&a| small(a)).collect();
    order.sort_by_key(|&a| (area[a as usize], a));
    let mut merged = Dsu::new(m);
    let mut merged_area = area.clone();
    for a in order {
        let ra = merged.find(a);
        if merged_area[ra as usize] >= min_area {
            continue; // grew big enough through earlier merges
        }
        let start = pairs.partition_point(|&(p, _)| p < a);
        let mut best: Option<(usize, u32)> = None;
        let mut i = start;
        while i < pairs.len() && pairs[i].0 == a {
            let b = pairs[i].1;
            let mut len = 0;
            while i < pairs.len() && pairs[i] == (a, b) {
                len += 1;
                i += 1;
            }
            if separate_objects && piece_object[b as usize] != piece_object[a as usize] {
                continue;
            }
            let rb = merged.find(b);
            if rb == ra {
                continue;
            }
            if best.is_none_or(|(l, bb)| len > l || (len == l && rb < bb)) {
                best = Some((len, rb));
            }
        }
        if let Some((_, rb)) = best {
            let total = merged_area[ra as usize] + merged_area[rb as usize];
            let r = merged.union(ra, rb);
            merged_area[r as usize] = total;
        }
    }
    // Final labels in scan order.
    let mut final_label = vec![u32::MAX; m];
    let mut count = 0u32;
    for p in 0..n {
        let r = merged.find(piece[p]) as usize;
        if final_label[r] == u32::MAX {
            final_label[r] = count;
            count += 1;
        }
        sp.labels[p] = final_label[r];
    }
    sp.count = count as usize;
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn lab_of_known_colours() {
        let white = linear_rgb_to_lab(Vec3::ONE);
        assert!((white[0] - 100.0).abs() < 0.01 && white[1].abs() < 0.01 && white[2].abs() < 0.01, "{white:?}");
        assert_eq!(linear_rgb_to_lab(Vec3::ZERO), [0.0, 0.0, 0.0]);
        // sRGB red (linear 1, 0, 0): L 53.24, a 80.09, b 67.20.
        let red = linear_rgb_to_lab(Vec3::X);
        assert!(
            (red[0] - 53.24).abs() < 0.05 && (red[1] - 80.09).abs() < 0.1 && (red[2] - 67.20).abs() < 0.1,
            "{red:?}"
        );
        // Mid grey (sRGB 0.5 = linear 0.2140): L 53.39.
        assert!((linear_rgb_to_lab(Vec3::splat(0.21404))[0] - 53.39).abs() < 0.05);
    }

    proptest! {
        #[test]
        fn fast_cbrt_is_accurate(t in 1e-6f32..1e3) {
            let e = (fast_cbrt(t) - t.cbrt()).abs() / t.cbrt();
            prop_assert!(e < 2e-6, "{t}: {e}");
        }
    }
}
