//! Where the planes go ("Planes everywhere": densest around the
//! subject's important parts, larger and calmer towards the edges, thinning out in the
//! corners): a density over the canvas from the pre-render. The split (`split`) gives each
//! plane about the same integral of it, so a plane's area goes as 1 / density.
//!
//! It lives on a fixed coarse grid (`GRID_COLUMNS` across) of the canvas, so the planes are
//! the same at any output resolution of one aspect.

use rayon::prelude::*;

/// Columns of the density grid (rows follow the aspect).
pub const GRID_COLUMNS: usize = 160;

/// Site density over the canvas, on the coarse grid, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Density {
    pub columns: usize,
    pub rows: usize,
    /// Relative site density per grid cell, in [1, detail].
    pub values: Vec<f64>,
}

/// Box blur of radius `r` cells along rows then columns, three passes (about a Gaussian of
/// sigma = r): separable and exact in any order, so deterministic.
fn blur(v: &mut [f64], cols: usize, rows: usize, r: usize) {
    if r == 0 {
        return;
    }
    let mut tmp = vec![0.0; v.len()];
    for _ in 0..3 {
        for y in 0..rows {
            for x in 0..cols {
                let (a, b) = (x.saturating_sub(r), (x + r).min(cols - 1));
                let s: f64 = v[y * cols + a..=y * cols + b].iter().sum();
                tmp[y * cols + x] = s / (b - a + 1) as f64;
            }
        }
        for y in 0..rows {
            let (a, b) = (y.saturating_sub(r), (y + r).min(rows - 1));
            for x in 0..cols {
                let s: f64 = (a..=b).map(|yy| tmp[yy * cols + x]).sum();
                v[y * cols + x] = s / (b - a + 1) as f64;
            }
        }
    }
}

/// Weights of the three cues in the density (they sum to 1): mesh saliency (the important
/// parts: a face, a hand), the subject's presence (planes over the subject rather than the
/// backdrop), and nearness to the subject's centre (calm edges and corners).
const W_SALIENCY: f64 = 0.5;
const W_SUBJECT: f64 = 0.3;
const W_CENTRE: f64 = 0.2;
/// The salient features the planes keep whole (`Cues::protect`): the cells whose own
/// saliency is in this top share of the subject's cells.
const PROTECT_SHARE: f64 = 0.04;
/// Steps of the density between 1 and `detail` (see `Density::new`).
const LEVELS: f64 = 32.0;

impl Density {
    /// The density of a `width` x `height` pre-render: `covered(i)` whether pixel i shows
    /// geometry, `saliency` the saliency map (None: no saliency). Site density is
    /// 1 + (detail - 1) D with D in [0, 1] the weighted cues (each blurred over a few percent
    /// of the canvas, saliency normalised by its maximum).
    pub fn new(
        width: u32,
        height: u32,
        covered: &(dyn Fn(usize) -> bool + Sync),
        saliency: Option<&[f32]>,
        detail: f64,
    ) -> Density {
        Cues::new(width, height, covered, saliency).density(detail)
    }
}

/// The weighted cues D of a pre-render, quantised to `LEVELS` steps, on the density grid:
/// everything of the density but `detail`, so a session keeps them while the pre-render is
/// the same and another detail costs one pass over the grid.
#[derive(Clone, Debug)]
pub struct Cues {
    pub columns: usize,
    pub rows: usize,
    /// round(D LEVELS) per grid cell, in 0..=LEVELS.
    pub steps: Vec<f64>,
    /// 1 on the cells of the salient features (an eye, a nose, a handle: the most salient
    /// cells of the subject, widened by a cell), else 0: the split keeps its lines off them.
    pub protect: Vec<f64>,
}

impl Cues {
    /// The cues of a pre-render (as `Density::new`).
    pub fn new(width: u32, height: u32, covered: &(dyn Fn(usize) -> bool + Sync), saliency: Option<&[f32]>) -> Cues {
        let (w, h) = (width as usize, height as usize);
        let columns = GRID_COLUMNS.min(w).max(1);
        let rows = ((columns as f64 * h as f64 / w as f64).round() as usize).clamp(1, h.max(1));
        // Area averages of coverage and saliency per grid cell (each pixel to the cell of its centre).
        let cell_of = |x: usize, y: usize| (y * rows / h) * columns + x * columns / w;
        let per_row: Vec<Vec<(f64, f64, f64)>> = (0..rows)
            .into_par_iter()
            .map(|gy| {
                let mut acc = vec![(0.0, 0.0, 0.0); columns];
                let (y0, y1) = ((gy * h).div_ceil(rows), ((gy + 1) * h).div_ceil(rows));
                for y in y0..y1.min(h) {
                    for x in 0..w {
                        let i = y * w + x;
                        let c = cell_of(x, y) - gy * columns;
                        let a = &mut acc[c];
                        a.0 += 1.0;
                        if covered(i) {
                            a.1 += 1.0;
                        }
                        if let Some(s) = saliency {
                            a.2 += s[i].clamp(0.0, 1.0) as f64;
                        }
                    }
                }
                acc
            })
            .collect();
        let n = columns * rows;
        let (mut cov, mut sal) = (vec![0.0; n], vec![0.0; n]);
        for (gy, row) in per_row.iter().enumerate() {
            for (gx, a) in row.iter().enumerate() {
                let k = gy * columns + gx;
                if a.0 > 0.0 {
                    cov[k] = a.1 / a.0;
                    sal[k] = a.2 / a.0;
                }
            }
        }
        let diag = ((columns * columns + rows * rows) as f64).sqrt();
        let protect = salient_cells(&sal, &cov, columns, rows);
        blur(&mut cov, columns, rows, (0.04 * diag).round() as usize);
        blur(&mut sal, columns, rows, (0.012 * diag).round() as usize);
        let smax = sal.iter().copied().fold(0.0, f64::max);
        if smax > 0.0 {
            sal.iter_mut().for_each(|s| *s /= smax);
        }
        let cmax = cov.iter().copied().fold(0.0, f64::max);
        if cmax > 0.0 {
            cov.iter_mut().for_each(|c| *c /= cmax);
        }
        // The subject's centre: the coverage-weighted centroid (the canvas centre without one).
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for (k, &c) in cov.iter().enumerate() {
            sx += c * ((k % columns) as f64 + 0.5);
            sy += c * ((k / columns) as f64 + 0.5);
            sw += c;
        }
        let centre = if sw > 0.0 { (sx / sw, sy / sw) } else { (columns as f64 / 2.0, rows as f64 / 2.0) };
        let half_diag = 0.5 * diag;
        let steps = (0..n)
            .map(|k| {
                let (x, y) = ((k % columns) as f64 + 0.5, (k / columns) as f64 + 0.5);
                let r = (((x - centre.0).powi(2) + (y - centre.1).powi(2)).sqrt() / half_diag).min(1.0);
                let d = W_SALIENCY * sal[k] + W_SUBJECT * cov[k] + W_CENTRE * (1.0 - r * r);
                // Quantised to `LEVELS` steps: the split compares planes' weights, and a
                // pre-render that differs by a few ulps (a scene moved or scaled) must give the
                // same planes, not a cascade of different choices.
                (d.clamp(0.0, 1.0) * LEVELS).round()
            })
            .collect();
        Cues { columns, rows, steps, protect }
    }

    /// The site density at `detail`: 1 + (detail - 1) D per cell.
    pub fn density(&self, detail: f64) -> Density {
        let values = self.steps.iter().map(|&q| 1.0 + (detail - 1.0).max(0.0) * q / LEVELS).collect();
        Density { columns: self.columns, rows: self.rows, values }
    }
}

/// The salient features on the grid (`Cues::protect`) from each cell's mean saliency and
/// coverage before blurring: the subject's cells (half covered or more) in the top
/// `PROTECT_SHARE` by saliency, widened by one cell. Ties at the cut are all in.
fn salient_cells(sal: &[f64], cov: &[f64], columns: usize, rows: usize) -> Vec<f64> {
    let mut values: Vec<f64> = sal.iter().zip(cov).filter(|(s, c)| **c >= 0.5 && **s > 0.0).map(|(s, _)| *s).collect();
    let mut out = vec![0.0; sal.len()];
    if values.is_empty() {
        return out;
    }
    let k = ((values.len() as f64 * (1.0 - PROTECT_SHARE)) as usize).min(values.len() - 1);
    let (_, cut, _) = values.select_nth_unstable_by(k, f64::total_cmp);
    let cut = *cut;
    for y in 0..rows {
        for x in 0..columns {
            let i = y * columns + x;
            if cov[i] >= 0.5 && sal[i] > 0.0 && sal[i] >= cut {
                for (dx, dy) in [(0i64, 0i64), (-1, 0), (1, 0), (0, -1), (0, 1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx >= 0 && ny >= 0 && (nx as usize) < columns && (ny as usize) < rows {
                        out[ny as usize * columns + nx as usize] = 1.0;
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_follows_saliency_subject_and_centre() {
        let (w, h) = (200u32, 150u32);
        // Saliency only in the left third; no geometry.
        let sal: Vec<f32> = (0..(w * h) as usize).map(|i| if (i % w as usize) < 66 { 1.0 } else { 0.0 }).collect();
        let d = Density::new(w, h, &|_| false, Some(&sal), 6.0);
        assert_eq!((d.columns, d.rows), (160, 120));
        assert!(d.values.iter().all(|&v| (1.0..=6.0).contains(&v)));
        let at = |x: usize, y: usize| d.values[y * d.columns + x];
        assert!(at(20, 60) > at(140, 60) + 2.0, "{} {}", at(20, 60), at(140, 60));
        // Centre beats corner at equal saliency.
        assert!(at(150, 60) > at(159, 0));
        // The features kept whole: salient cells of the subject only.
        let cov = Cues::new(w, h, &|i| (i % w as usize) < 100, Some(&sal));
        assert!(cov.protect.contains(&1.0));
        assert!(
            cov.protect.iter().enumerate().all(|(k, &p)| p == 0.0 || k % cov.columns < 90),
            "features off the subject"
        );
        // Detail 1: uniform.
        let u = Density::new(w, h, &|i| i % 2 == 0, Some(&sal), 1.0);
        assert!(u.values.iter().all(|&v| v == 1.0));
    }
}
