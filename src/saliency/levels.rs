//! The scale space of Lee, Varshney and Jacobs (2005):
//! Gaussian-weighted means of mean curvature at eight distinct scales, five centre-surround
//! levels, per-level normalisation, non-linear suppression, sum, final scaling to [0, 1].

use glam::DVec3;
use rayon::prelude::*;

use super::neighbourhood::{Grid, dist2};
use super::surface::Adjacency;

/// Scale multipliers of the five levels' fine Gaussians: sigma_i = {2, 3, 4, 5, 6} eps.
pub const LEVEL_SCALES: [f64; 5] = [2.0, 3.0, 4.0, 5.0, 6.0];
/// The eight distinct sigmas (in eps) the five levels need: the fine {2..6} and their
/// doubles {4, 6, 8, 10, 12} overlap in 4 and 6.
pub const SIGMA_SCALES: [f64; 8] = [2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0];
/// For level i, the indices in `SIGMA_SCALES` of sigma_i and 2 sigma_i.
pub const LEVEL_PAIRS: [(usize, usize); 5] = [(0, 2), (1, 4), (2, 5), (3, 6), (4, 7)];

/// Noise floor of a level's centre-surround difference, as a fraction of the mean |H|.
///
/// Why: the method asks that a mesh with no variation (a sphere) gets 0, but a discrete
/// estimator never returns an exactly constant H on a tessellated sphere; normalising that
/// residue to [0, 1] would turn discretisation noise into full-range saliency. Differences
/// below this fraction of the mesh's typical curvature are treated as no variation: they are
/// subtracted from every vertex of every level before normalisation (a soft threshold, so
/// real features are shifted by a negligible amount, not cut). Measured residues (largest level
/// maximum / mean |H|): below 3e-5 on icospheres of 1-5 subdivisions and sphere_1280, 0.0075 on
/// a 16x8 UV sphere (the coarsest tested), against 0.8 to 2.0 on the shared models (suzanne,
/// teapot, spot, bunny, venus): the floor sits 4x above the first and 25x below the second
/// (`tests/saliency.rs::noise_floor_has_margin`).
pub const NOISE_FLOOR: f64 = 0.03;

/// eps of Lee et al. 2005: 0.3% of the bounding-box diagonal, raised to half the mean edge
/// length on coarse meshes so every 2-sigma neighbourhood holds at least a ring.
pub fn epsilon(diagonal: f64, mean_edge: f64) -> f64 {
    (0.003 * diagonal).max(0.5 * mean_edge)
}

/// G(v, sigma) for every vertex and every sigma in `sigmas` (ascending): the mean of `h` over
/// the vertices strictly within 2 sigma of v (v included), weighted by exp(-d^2 / (2 sigma^2)).
/// Returns n rows of `sigmas.len()` values. Exact; one grid pass serves every sigma.
pub fn gaussian_means(points: &[DVec3], h: &[f64], sigmas: &[f64]) -> Vec<f64> {
    let k = sigmas.len();
    let n = points.len();
    if n == 0 || k == 0 {
        return Vec::new();
    }
    assert!(k <= SIGMA_SCALES.len() && sigmas.windows(2).all(|w| w[0] < w[1]));
    let rmax = 2.0 * sigmas[k - 1];
    // Cells of a third of the reach: fewer wasted candidates than halves, few enough offsets.
    let grid = Grid::new(points, rmax / 3.0);
    let mut cut2 = [0.0f64; 8];
    let mut inv = [0.0f64; 8];
    for (j, s) in sigmas.iter().enumerate() {
        cut2[j] = 4.0 * s * s;
        inv[j] = 1.0 / (2.0 * s * s);
    }
    let r2max = cut2[k - 1];
    // exp(-d^2 / (2 sigma^2)) = exp(-d^2 / (2 (2 sigma)^2))^4: a sigma whose double is also in
    // the set takes its weight from that one by two squarings. For the eight SIGMA_SCALES this
    // leaves 3 exponentials per pair at most (sigmas 8, 10 and 12 eps) instead of 8.
    let mut double = [usize::MAX; 8];
    for i in 0..k {
        for j in i + 1..k {
            if (sigmas[j] - 2.0 * sigmas[i]).abs() <= 1e-12 * sigmas[j] {
                double[i] = j;
            }
        }
    }
    let per_cell: Vec<Vec<f64>> = (0..grid.cell_count())
        .into_par_iter()
        .map_init(Buffers::default, |b, c| {
            b.gather(&grid, c, rmax, points, h);
            let targets = grid.cell_points(c);
            let mut out = Vec::with_capacity(targets.len() * k);
            for &t in targets {
                let p = points[t as usize];
                let mut num = [0.0f64; 8];
                let mut den = [0.0f64; 8];
                for j in 0..b.x.len() {
                    let d2 = dist2(DVec3::new(b.x[j], b.y[j], b.z[j]), p);
                    if d2 >= r2max {
                        continue;
                    }
                    let hj = b.h[j];
                    let mut w = [0.0f64; 8];
                    let mut l = k;
                    // Descending, so a sigma's double (when present) is already weighted.
                    while l > 0 && d2 < cut2[l - 1] {
                        l -= 1;
                        w[l] = if double[l] != usize::MAX {
                            let w2 = w[double[l]] * w[double[l]];
                            w2 * w2
                        } else {
                            (-d2 * inv[l]).exp()
                        };
                        num[l] += w[l] * hj;
                        den[l] += w[l];
                    }
                }
                // den >= 1: the vertex itself is in every neighbourhood.
                out.extend((0..k).map(|l| num[l] / den[l]));
            }
            out
        })
        .collect();
    let mut means = vec![0.0; n * k];
    for (c, vals) in per_cell.iter().enumerate() {
        for (r, &t) in grid.cell_points(c).iter().enumerate() {
            means[t as usize * k..(t as usize + 1) * k].copy_from_slice(&vals[r * k..(r + 1) * k]);
        }
    }
    means
}

/// Candidate pairs `gaussian_means` visits when its largest sigma is `sigma_max`: the same
/// grid, counted without computing a distance.
pub fn exact_work(points: &[DVec3], sigma_max: f64) -> u64 {
    let rmax = 2.0 * sigma_max;
    Grid::new(points, rmax / 3.0).candidate_pairs(rmax)
}

/// A cell's candidates copied into contiguous arrays.
#[derive(Default)]
struct Buffers {
    ids: Vec<u32>,
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    h: Vec<f64>,
}

impl Buffers {
    fn gather(&mut self, grid: &Grid, c: usize, radius: f64, points: &[DVec3], h: &[f64]) {
        self.ids.clear();
        grid.candidates(c, radius, &mut self.ids);
        self.x.clear();
        self.y.clear();
        self.z.clear();
        self.h.clear();
        for &i in &self.ids {
            let p = points[i as usize];
            self.x.push(p.x);
            self.y.push(p.y);
            self.z.push(p.z);
            self.h.push(h[i as usize]);
        }
    }
}

/// Values of a normalised level (maximum 1) closer than this count as equal in step 5 (of
/// Lee et al.'s normalisation: local maxima, the global maximum M_i, mbar_i).
///
/// Why: on a solid of revolution (the still life's fruit, jug, bowl) vertices of one ring hold
/// values equal in exact arithmetic, and their computed means differ in the last bits only,
/// which depend on libm's `exp` and the summation order. A strict comparison would let those
/// bits decide which vertex is a peak; a few-ulp change of the means moved the apple's
/// saliency by up to 0.29. Rounding errors of the means reach ~1e-15 of the level's maximum,
/// real differences between neighbouring peaks are orders above 1e-9.
pub const TIE: f64 = 1e-9;

/// Local maxima of `values` (a level normalised to maximum 1) at scale `radius`: vertices whose
/// value is above `TIE` and which no other vertex strictly within `radius` exceeds by more than
/// `TIE`.
///
/// Why this definition: a level's peaks live at its own scale sigma_i, so "maximum within
/// sigma_i" counts one peak per feature whatever the mesh's resolution, whereas one-ring maxima
/// multiply with tessellation density (every ripple of a fine mesh is a peak) and would make
/// the suppression depend on resolution. Zero-valued vertices (no contrast) are never peaks, nor
/// are values within `TIE` of 0 (a vertex at the noise floor in exact arithmetic). Vertices tied
/// within `TIE` (a ring of a symmetric solid) are all peaks: the rounding of their values cannot
/// decide.
pub fn local_maxima(points: &[DVec3], values: &[f64], radius: f64, adjacency: Option<&Adjacency>) -> Vec<bool> {
    let n = points.len();
    if n == 0 {
        return Vec::new();
    }
    let r2 = radius * radius;
    // Cheap necessary condition first: no one-ring neighbour within the radius is larger.
    // Most vertices fail it, so the radius scan below runs for a few candidates only.
    let candidate: Vec<bool> = (0..n)
        .into_par_iter()
        .map(|v| {
            values[v] > TIE
                && adjacency.is_none_or(|adj| {
                    adj.of(v)
                        .iter()
                        .all(|&u| values[u as usize] <= values[v] + TIE || dist2(points[u as usize], points[v]) >= r2)
                })
        })
        .collect();
    let grid = Grid::new(points, radius);
    let per_cell: Vec<Vec<bool>> = (0..grid.cell_count())
        .into_par_iter()
        .map_init(Vec::new, |cand: &mut Vec<u32>, c| {
            let targets = grid.cell_points(c);
            if !targets.iter().any(|&t| candidate[t as usize]) {
                return vec![false; targets.len()];
            }
            cand.clear();
            grid.candidates(c, radius, cand);
            targets
                .iter()
                .map(|&t| {
                    let (p, v) = (points[t as usize], values[t as usize]);
                    candidate[t as usize]
                        && cand
                            .iter()
                            .all(|&j| j == t || values[j as usize] <= v + TIE || dist2(points[j as usize], p) >= r2)
                })
                .collect()
        })
        .collect();
    let mut out = vec![false; n];
    for (c, flags) in per_cell.iter().enumerate() {
        for (r, &t) in grid.cell_points(c).iter().enumerate() {
            out[t as usize] = flags[r];
        }
    }
    out
}

/// Everything after the Gaussian means: centre-surround, noise floor, per-level normalisation,
/// suppression by (M - mbar)^2, sum, scaling to [0, 1]. `means` holds n rows of the eight
/// `SIGMA_SCALES` means; `eps` is the mesh's eps. Returns the saliency per vertex.
///
/// Normalisation divides by the level's maximum (S_i >= 0, so this maps onto [0, 1] and keeps
/// "no contrast" at 0). M_i is then 1; mbar_i is the mean of the local maxima other than one
/// vertex holding the global maximum, 0 when there is none (a single peak is maximally
/// distinctive). Values within `TIE` count as equal, so ties of exact arithmetic never hang on
/// rounding. If suppression removes every level (each has several equal top peaks, as on
/// a perfectly symmetric solid) the unsuppressed sum is used, so the result still shows the
/// geometry. A mesh with no variation gets 0 everywhere.
pub fn combine(points: &[DVec3], adjacency: &Adjacency, h: &[f64], means: &[f64], eps: f64) -> Vec<f64> {
    let n = points.len();
    let ns = SIGMA_SCALES.len();
    if n == 0 {
        return Vec::new();
    }
    let mean_abs_h = h.iter().map(|x| x.abs()).sum::<f64>() / n as f64;
    let floor = NOISE_FLOOR * mean_abs_h;
    let mut total = vec![0.0f64; n];
    let mut plain = vec![0.0f64; n];
    let mut any_level = false;
    let mut any_weight = false;
    for (li, &(fine, coarse)) in LEVEL_PAIRS.iter().enumerate() {
        // Element-wise steps and maxima run in parallel (same bits: no sum changes order).
        let mut s: Vec<f64> = means.par_chunks(ns).map(|m| ((m[fine] - m[coarse]).abs() - floor).max(0.0)).collect();
        let max = s.par_iter().cloned().reduce(|| 0.0f64, f64::max);
        if !(max > 0.0) || !max.is_finite() {
            continue;
        }
        any_level = true;
        s.par_iter_mut().for_each(|x| *x /= max);
        let peaks = local_maxima(points, &s, LEVEL_SCALES[li] * eps, Some(adjacency));
        // Step 5's "global maximum" M_i is one value, 1; the vertex holding it is one peak
        // within TIE of 1 (the first in canonical order). When a symmetric solid has several
        // such peaks, the others stay "other local maxima" (they are as distinctive as M_i,
        // and pull mbar towards 1), and which one is left out moves mbar by TIE at most.
        let top = peaks.par_iter().zip(s.par_iter()).position_first(|(&p, &x)| p && x >= 1.0 - TIE);
        let (mut sum, mut count) = (0.0f64, 0usize);
        for v in 0..n {
            if peaks[v] && Some(v) != top {
                sum += s[v];
                count += 1;
            }
        }
        let mbar = if count > 0 { sum / count as f64 } else { 0.0 };
        // mbar within TIE of M_i = 1 (every peak tied at the top) is a weight of 0, not the
        // square of a rounding error: otherwise ratios of such residues would decide the sum.
        let weight = if 1.0 - mbar <= TIE { 0.0 } else { (1.0 - mbar).powi(2) };
        any_weight |= weight > 0.0;
        total.par_iter_mut().zip(plain.par_iter_mut()).zip(s.par_iter()).for_each(|((t, p), x)| {
            *t += weight * x;
            *p += x;
        });
    }
    if !any_level {
        return vec![0.0; n];
    }
    let mut out = if any_weight { total } else { plain };
    let max = out.par_iter().cloned().reduce(|| 0.0f64, f64::max);
    if max > 0.0 && max.is_finite() {
        out.par_iter_mut().for_each(|x| *x /= max);
    } else {
        out.iter_mut().for_each(|x| *x = 0.0);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_sigmas_serve_five_levels() {
        for (i, &(f, c)) in LEVEL_PAIRS.iter().enumerate() {
            assert_eq!(SIGMA_SCALES[f], LEVEL_SCALES[i]);
            assert_eq!(SIGMA_SCALES[c], 2.0 * LEVEL_SCALES[i]);
        }
    }

    #[test]
    fn coarse_meshes_raise_eps_to_half_an_edge() {
        assert_eq!(epsilon(100.0, 0.1), 0.3);
        assert_eq!(epsilon(1.0, 0.1), 0.05);
    }

    #[test]
    fn gaussian_means_match_the_definition() {
        // Points on a line 1 apart; sigma 0.75 reaches d < 1.5, i.e. one neighbour each side.
        let pts: Vec<DVec3> = (0..5).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        let h = vec![0.0, 0.0, 3.0, 0.0, 0.0];
        let g = gaussian_means(&pts, &h, &[0.75, 1.0]);
        let w1 = (-1.0f64 / (2.0 * 0.5625)).exp();
        assert!((g[2 * 2] - 3.0 / (1.0 + 2.0 * w1)).abs() < 1e-12);
        assert!((g[2] - 3.0 * w1 / (1.0 + 2.0 * w1)).abs() < 1e-12);
        assert_eq!(g[0], 0.0); // vertex 2 is 2 away from 0: outside 2 sigma = 1.5
        // sigma 1: cut at d < 2, so distance 2 is out and distance 1 is in.
        let w = (-0.5f64).exp();
        assert!((g[2 * 2 + 1] - 3.0 / (1.0 + 2.0 * w)).abs() < 1e-12);
        assert_eq!(g[1], 0.0);
    }

    #[test]
    fn local_maxima_are_scaled_and_keep_ties() {
        let pts: Vec<DVec3> = (0..7).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        let v = vec![0.0, 0.5, 0.2, 0.9, 0.9, 0.1, 0.3];
        // With or without the one-ring shortcut (a path 0-1-...-6), the same answer.
        let edges: Vec<(u32, u32, u32)> = (0..6).map(|i| (i, i + 1, 1)).collect();
        let adj = Adjacency::new(7, &edges);
        for a in [None, Some(&adj)] {
            // The tie 0.9/0.9 (neighbours): both are peaks.
            assert_eq!(local_maxima(&pts, &v, 1.5, a), vec![false, true, false, true, true, false, true]);
            // A wider radius keeps only the strongest: the tie 0.9/0.9, both.
            assert_eq!(local_maxima(&pts, &v, 3.5, a), vec![false, false, false, true, true, false, false]);
            assert_eq!(local_maxima(&pts, &v, 0.5, a), vec![false, true, true, true, true, true, true]);
        }
    }

    #[test]
    fn ties_within_tie_are_peaks_and_real_differences_decide() {
        let pts: Vec<DVec3> = (0..5).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        // 0.9 and 0.9 + 3 ulps: both peaks, whichever way the rounding went.
        let up = 0.9f64 + 3.0 * f64::EPSILON;
        for v in [vec![0.1, 0.9, up, 0.1, 0.0], vec![0.1, up, 0.9, 0.1, 0.0]] {
            assert_eq!(local_maxima(&pts, &v, 1.5, None), vec![false, true, true, false, false]);
        }
        // A difference of 1e-6 is real: only the larger is a peak.
        let v = vec![0.1, 0.9, 0.9 + 1e-6, 0.1, 0.0];
        assert_eq!(local_maxima(&pts, &v, 1.5, None), vec![false, false, true, false, false]);
        // Values at rounding level above 0 are no peaks.
        let v = vec![0.0, 1e-15, 0.0, 0.0, 0.0];
        assert_eq!(local_maxima(&pts, &v, 1.5, None), vec![false; 5]);
    }
}
