//! Clustered Gaussian means with a bounded cost: what `SaliencyMethod::Clustered` (and `Auto`
//! above its budget) evaluates instead of the exact sums, whose cost grows with the number of
//! vertices within 2 sigma (a 2M-vertex mesh visits ~1e11 pairs at the largest sigma).
//!
//! Per sigma, vertices are bucketed into cells of side sigma / `BETA`, cells into blocks of
//! `BETA`^3 (side sigma). Each cell is a source cluster (vertex count, summed curvature,
//! centroid). Every block of target vertices is then evaluated one of two ways, whichever
//! costs fewer candidate evaluations, counted before doing either:
//! - exactly: each target vertex against every vertex of the blocks within reach (the
//!   definition's sum, hard cut-off at 2 sigma);
//! - clustered: target vertices in groups of `GROUP`^3 cells (single cells when the sigma's
//!   evaluation stays under `FINE_BUDGET` that way; and a sigma whose exact evaluation stays
//!   under it is exact everywhere), each group against every source
//!   cluster within reach, evaluated once at the group's centroid with its gradient, and
//!   carried to each vertex by a first-order step (`kernels::Expansion`). A cluster
//!   straddling the cut-off counts in proportion (a ramp one cell wide).
//!
//! Cost: a clustered group meets at most the clusters within 2 sigma + half a cell, a number
//! fixed by `BETA` (~350 on a surface), whatever the density; a block is exact only when that
//! is cheaper. So sparse regions (and small meshes) are exact and the work per vertex is
//! bounded: at most (candidates per group) x 8 sigmas per group, plus O(n log n) bucketing.
//! Everything after the means (centre-surround, normalisation, local maxima, suppression) is
//! the exact definition. Errors against exact, per mesh class: docs/saliency.md.
//!
//! Deterministic: blocks are evaluated independently in a fixed candidate order and the
//! kernels give the same bits on any CPU (`kernels`), so results do not depend on the thread
//! count (tested).

use glam::DVec3;
use rayon::prelude::*;

use super::kernels::{self, Expansion, Kernel, LANES, LANES64};
use super::neighbourhood::bucket_order;

/// Cluster cell side = sigma / BETA; blocks are BETA cells a side (side sigma).
pub const BETA: f64 = 4.0;

/// Target groups are GROUP^3 cells: fewer evaluations (about 4x on a surface) for a small loss
/// of accuracy (mean error 0.0003 -> 0.0006 on a uniform 62K mesh; docs/saliency.md), taken
/// only where single cells would cost more than `FINE_BUDGET`.
pub const GROUP: i64 = 2;

/// A sigma whose evaluation with single-cell groups costs at most this many candidate
/// evaluations (a few hundredths of a second) uses single cells: accuracy where it is cheap.
const FINE_BUDGET: f64 = 1.5e7;

/// Relative cost of one clustered candidate evaluation (f32, eight lanes) against one exact one
/// (f64, four lanes), measured: about the same.
const CLUSTER_COST: f64 = 1.0;

/// Approximate G(v, sigma) for every vertex and sigma, laid out as `levels::gaussian_means`
/// lays them out (n rows of `sigmas.len()` values).
pub fn clustered_means(points: &[DVec3], h: &[f64], sigmas: &[f64]) -> Vec<f64> {
    clustered_means_with(points, h, sigmas, BETA, GROUP).0
}

/// How one sigma was evaluated: vertices whose block was exact, and candidate evaluations made.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Work {
    pub exact_vertices: usize,
    pub candidates: u64,
}

/// `clustered_means` with explicit cell size (sigma / `beta`, blocks of round(beta) cells) and
/// target groups of `group`^3 cells (single cells where those cost at most `FINE_BUDGET`);
/// also returns the work done per sigma.
pub fn clustered_means_with(
    points: &[DVec3],
    h: &[f64],
    sigmas: &[f64],
    beta: f64,
    group: i64,
) -> (Vec<f64>, Vec<Work>) {
    let n = points.len();
    let k = sigmas.len();
    let mut means = vec![0.0; n * k];
    if n == 0 {
        return (means, vec![Work::default(); k]);
    }
    let bounds = points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), p| (l.min(*p), h.max(*p)));
    let mut work = Vec::with_capacity(k);
    for (j, &sigma) in sigmas.iter().enumerate() {
        let (g, w) = one_sigma(points, h, bounds, sigma, beta, group);
        work.push(w);
        means.par_chunks_mut(k).zip(g.par_iter()).for_each(|(row, v)| row[j] = *v);
    }
    (means, work)
}

/// Points sorted by (block, cell within the block, id), with cell and block ranges; blocks are
/// found through a dense array over the bounding box.
struct Blocked {
    /// Block side, cells per block side, origin and block counts per axis.
    side: f64,
    per: i64,
    dims: [i64; 3],
    /// Block index per dense position, or u32::MAX.
    dense: Vec<u32>,
    /// Per block: its coordinates and the range of its cells (`block_cells[b]..[b + 1]`).
    block_coords: Vec<[i64; 3]>,
    block_cells: Vec<u32>,
    /// Per cell: its coordinates (in cells) and the range of its points in `ids`.
    cell_coords: Vec<[i64; 3]>,
    cell_start: Vec<u32>,
    ids: Vec<u32>,
}

impl Blocked {
    fn new(points: &[DVec3], (lo, hi): (DVec3, DVec3), cell: f64, per: i64) -> Blocked {
        let per = per.clamp(1, 8);
        // Bits per axis of a cell's position within its block, and the sort key's layout:
        // block (dense index) | cell within block | point id.
        let lb = (64 - ((per - 1).max(1) as u64).leading_zeros()) as i64;
        let max_blocks = 1u64 << (32 - 3 * lb);
        let ext = hi - lo;
        let mut side = cell * per as f64;
        let dims_for = |s: f64| [ext.x, ext.y, ext.z].map(|e| (e / s) as i64 + 1);
        // A sigma tiny against the mesh (never the case with the method's eps) coarsens the grid so
        // the dense array stays bounded.
        while dims_for(side).iter().map(|&d| d as u64).product::<u64>() > max_blocks.min(1 << 24) {
            side *= 1.25;
        }
        let dims = dims_for(side);
        let cell = side / per as f64;
        let inv = 1.0 / cell;
        let keyed: Vec<u64> = points
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let q = (*p - lo) * inv;
                let c = [q.x as i64, q.y as i64, q.z as i64];
                let b = [0, 1, 2].map(|a| (c[a] / per).min(dims[a] - 1));
                let l = [0, 1, 2].map(|a| (c[a] - b[a] * per).clamp(0, per - 1));
                let lin = (b[0] * dims[1] + b[1]) * dims[2] + b[2];
                let local = (l[0] << (2 * lb)) | (l[1] << lb) | l[2];
                ((((lin as u64) << (3 * lb)) | local as u64) << 32) | i as u64
            })
            .collect();
        // Sorted by block with a counting sort, then within each (small) block.
        let shift = 32 + 3 * lb;
        let block: Vec<u32> = keyed.par_iter().map(|k| (k >> shift) as u32).collect();
        let blocks = (dims[0] * dims[1] * dims[2]) as usize;
        let mut keys: Vec<u64> = bucket_order(&block, blocks).into_par_iter().map(|i| keyed[i as usize]).collect();
        keys.par_chunk_by_mut(|a, b| a >> shift == b >> shift).for_each(|c| c.sort_unstable());
        let ids: Vec<u32> = keys.par_iter().map(|k| *k as u32).collect();
        let mut grid = Blocked {
            side,
            per,
            dims,
            dense: vec![u32::MAX; (dims[0] * dims[1] * dims[2]) as usize],
            block_coords: Vec::new(),
            block_cells: Vec::new(),
            cell_coords: Vec::new(),
            cell_start: Vec::new(),
            ids,
        };
        let (mut last_cell, mut last_block) = (u64::MAX, u64::MAX);
        let lmask = (1i64 << lb) - 1;
        for (i, key) in keys.iter().enumerate() {
            let ck = key >> 32;
            if ck == last_cell {
                continue;
            }
            let bk = ck >> (3 * lb);
            let lin = bk as i64;
            let b = [lin / (dims[1] * dims[2]), (lin / dims[2]) % dims[1], lin % dims[2]];
            if bk != last_block {
                grid.dense[lin as usize] = grid.block_coords.len() as u32;
                grid.block_coords.push(b);
                grid.block_cells.push(grid.cell_start.len() as u32);
                last_block = bk;
            }
            let local = (ck & ((1 << (3 * lb)) - 1)) as i64;
            let l = [(local >> (2 * lb)) & lmask, (local >> lb) & lmask, local & lmask];
            grid.cell_coords.push([0, 1, 2].map(|a| b[a] * per + l[a]));
            grid.cell_start.push(i as u32);
            last_cell = ck;
        }
        grid.cell_start.push(keys.len() as u32);
        grid.block_cells.push(grid.cell_coords.len() as u32);
        grid
    }

    fn cell(&self) -> f64 {
        self.side / self.per as f64
    }

    /// Block offsets whose boxes come within `reach` of the centre block's box.
    fn offsets(&self, reach: f64) -> Vec<[i64; 3]> {
        let r = reach / self.side;
        let m = r.ceil() as i64;
        let gap = |d: i64| (d.abs() - 1).max(0) as f64;
        let mut out = Vec::new();
        for dx in -m..=m {
            for dy in -m..=m {
                for dz in -m..=m {
                    if gap(dx).powi(2) + gap(dy).powi(2) + gap(dz).powi(2) < r * r {
                        out.push([dx, dy, dz]);
                    }
                }
            }
        }
        out
    }

    fn block_at(&self, b: [i64; 3]) -> Option<usize> {
        if (0..3).any(|a| b[a] < 0 || b[a] >= self.dims[a]) {
            return None;
        }
        let v = self.dense[((b[0] * self.dims[1] + b[1]) * self.dims[2] + b[2]) as usize];
        (v != u32::MAX).then_some(v as usize)
    }

    /// The range in `ids` of block `b`'s points (contiguous: sorted by block first).
    fn points_of_block(&self, b: usize) -> std::ops::Range<usize> {
        self.cell_start[self.block_cells[b] as usize] as usize
            ..self.cell_start[self.block_cells[b + 1] as usize] as usize
    }

    fn cells_of_block(&self, b: usize) -> std::ops::Range<usize> {
        self.block_cells[b] as usize..self.block_cells[b + 1] as usize
    }

    fn points_of_cell(&self, c: usize) -> std::ops::Range<usize> {
        self.cell_start[c] as usize..self.cell_start[c + 1] as usize
    }
}

/// Candidates gathered for one block, padded to a multiple of `LANES`.
#[derive(Default)]
struct Scratch {
    near: Vec<u32>,
    /// Exact blocks: candidate vertices in f64.
    px: Vec<f64>,
    py: Vec<f64>,
    pz: Vec<f64>,
    ph: Vec<f64>,
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    count: Vec<f32>,
    h: Vec<f32>,
    groups: Vec<Vec<usize>>,
}

impl Scratch {
    fn clear(&mut self) {
        for v in [&mut self.x, &mut self.y, &mut self.z, &mut self.count, &mut self.h] {
            v.clear();
        }
    }

    /// Pads with far-away candidates of zero weight.
    fn pad(&mut self) {
        let len = self.x.len().div_ceil(LANES) * LANES;
        for v in [&mut self.x, &mut self.y, &mut self.z] {
            v.resize(len, 1e30);
        }
        self.count.resize(len, 0.0);
        self.h.resize(len, 0.0);
    }
}

/// f32 coordinates relative to `centre` (within the mesh's extent, so their rounding is ~1e-7
/// of the mesh's size, well below the scales 2 sigma >= 1.2% of its diagonal).
fn rel(p: DVec3, centre: DVec3) -> [f32; 3] {
    let r = p - centre;
    [r.x as f32, r.y as f32, r.z as f32]
}

fn one_sigma(
    points: &[DVec3],
    h: &[f64],
    bounds: (DVec3, DVec3),
    sigma: f64,
    beta: f64,
    group: i64,
) -> (Vec<f64>, Work) {
    let grid = Blocked::new(points, bounds, sigma / beta, beta.round() as i64);
    let cell = grid.cell();
    let centre = (bounds.0 + bounds.1) * 0.5;
    // Points in grid order (f64, for exact blocks), clusters in f32 (for clustered ones).
    let sorted: Vec<(DVec3, f64)> = grid.ids.par_iter().map(|&i| (points[i as usize], h[i as usize])).collect();
    let vx: Vec<f64> = sorted.par_iter().map(|s| s.0.x).collect();
    let vy: Vec<f64> = sorted.par_iter().map(|s| s.0.y).collect();
    let vz: Vec<f64> = sorted.par_iter().map(|s| s.0.z).collect();
    let vh: Vec<f64> = sorted.par_iter().map(|s| s.1).collect();
    // Source clusters: count, summed curvature, centroid.
    let clusters: Vec<(f64, f64, DVec3)> = (0..grid.cell_coords.len())
        .into_par_iter()
        .map(|c| {
            let pts = &sorted[grid.points_of_cell(c)];
            let (hs, ps) = pts.iter().fold((0.0, DVec3::ZERO), |(hs, ps), (p, hv)| (hs + hv, ps + *p));
            (pts.len() as f64, hs, ps / pts.len() as f64)
        })
        .collect();
    let rels: Vec<[f32; 3]> = clusters.par_iter().map(|c| rel(c.2, centre)).collect();
    let cx: Vec<f32> = rels.par_iter().map(|r| r[0]).collect();
    let cy: Vec<f32> = rels.par_iter().map(|r| r[1]).collect();
    let cz: Vec<f32> = rels.par_iter().map(|r| r[2]).collect();
    let cn: Vec<f32> = clusters.par_iter().map(|c| c.0 as f32).collect();
    let ch: Vec<f32> = clusters.par_iter().map(|c| c.1 as f32).collect();
    let kernel = Kernel::new(sigma, cell);
    // As `levels::gaussian_means` has them, so exact blocks make the same decisions.
    let (cut2, inv) = (4.0 * sigma * sigma, 1.0 / (2.0 * sigma * sigma));
    // Clusters weigh up to half a cell beyond 2 sigma (a little more: the ramp's expansion).
    let offsets = grid.offsets(2.0 * sigma + 0.55 * cell);
    let per = grid.per;
    // Costs counted before evaluating: every block exact, and each block's cheaper way with
    // single-cell groups. Within `FINE_BUDGET`, accuracy is bought: the whole sigma exact, or
    // single cells.
    let (all_exact, fine): (f64, f64) = (0..grid.block_coords.len())
        .into_par_iter()
        .map(|b| {
            let bc = grid.block_coords[b];
            let (mut points, mut cells) = (0usize, 0usize);
            for o in &offsets {
                if let Some(q) = grid.block_at([bc[0] + o[0], bc[1] + o[1], bc[2] + o[2]]) {
                    points += grid.points_of_block(q).len();
                    cells += grid.cells_of_block(q).len();
                }
            }
            let exact = grid.points_of_block(b).len() as f64 * points as f64;
            (exact, exact.min(CLUSTER_COST * grid.cells_of_block(b).len() as f64 * cells as f64))
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let exact_everywhere = all_exact <= FINE_BUDGET;
    let group = if fine <= FINE_BUDGET { 1 } else { group.clamp(1, per) };
    let groups_per_side = (per + group - 1) / group;
    let per_block: Vec<(Vec<f64>, Work)> = (0..grid.block_coords.len())
        .into_par_iter()
        .map_init(Scratch::default, |s, b| {
            let bc = grid.block_coords[b];
            s.near.clear();
            let (mut near_points, mut near_cells) = (0usize, 0usize);
            for o in &offsets {
                if let Some(q) = grid.block_at([bc[0] + o[0], bc[1] + o[1], bc[2] + o[2]]) {
                    s.near.push(q as u32);
                    near_points += grid.points_of_block(q).len();
                    near_cells += grid.cells_of_block(q).len();
                }
            }
            let targets = grid.points_of_block(b);
            let v0 = targets.start;
            // Target groups: cells of the block by their position within it.
            s.groups.resize((groups_per_side * groups_per_side * groups_per_side) as usize, Vec::new());
            s.groups.iter_mut().for_each(|g| g.clear());
            for c in grid.cells_of_block(b) {
                let l = [0, 1, 2].map(|a| (grid.cell_coords[c][a] - bc[a] * per) / group);
                s.groups[((l[0] * groups_per_side + l[1]) * groups_per_side + l[2]) as usize].push(c);
            }
            let n_groups = s.groups.iter().filter(|g| !g.is_empty()).count();
            let exact_cost = targets.len() as f64 * near_points as f64;
            let clustered_cost = CLUSTER_COST * n_groups as f64 * near_cells as f64;
            let mut out = vec![0.0; targets.len()];
            s.clear();
            if exact_everywhere || exact_cost <= clustered_cost {
                for v in [&mut s.px, &mut s.py, &mut s.pz, &mut s.ph] {
                    v.clear();
                }
                for &q in &s.near {
                    let r = grid.points_of_block(q as usize);
                    s.px.extend_from_slice(&vx[r.clone()]);
                    s.py.extend_from_slice(&vy[r.clone()]);
                    s.pz.extend_from_slice(&vz[r.clone()]);
                    s.ph.extend_from_slice(&vh[r]);
                }
                // Padding far away (squared distances stay finite), of zero weight.
                let len = s.px.len().div_ceil(LANES64) * LANES64;
                for v in [&mut s.px, &mut s.py, &mut s.pz] {
                    v.resize(len, 1e150);
                }
                s.ph.resize(len, 0.0);
                for v in targets.clone() {
                    let (num, den) = kernels::exact_sum(cut2, inv, &s.px, &s.py, &s.pz, &s.ph, sorted[v].0);
                    // den >= 1: the vertex is its own neighbour.
                    out[v - v0] = num / den;
                }
                let work = Work { exact_vertices: targets.len(), candidates: (targets.len() * len) as u64 };
                return (out, work);
            }
            for &q in &s.near {
                let r = grid.cells_of_block(q as usize);
                s.x.extend_from_slice(&cx[r.clone()]);
                s.y.extend_from_slice(&cy[r.clone()]);
                s.z.extend_from_slice(&cz[r.clone()]);
                s.count.extend_from_slice(&cn[r.clone()]);
                s.h.extend_from_slice(&ch[r]);
            }
            s.pad();
            for g in &s.groups {
                if g.is_empty() {
                    continue;
                }
                let (sum, count) = g
                    .iter()
                    .fold((DVec3::ZERO, 0.0), |(p, n), &c| (p + clusters[c].2 * clusters[c].0, n + clusters[c].0));
                // The expansion point as the kernels see it (rounded to f32).
                let m = rel(sum / count, centre);
                let mp = centre + DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64);
                let e: Expansion = kernels::clustered_sum(&kernel, &s.x, &s.y, &s.z, &s.count, &s.h, m);
                for &c in g {
                    for v in grid.points_of_cell(c) {
                        out[v - v0] = e.at(sorted[v].0 - mp);
                    }
                }
            }
            (out, Work { exact_vertices: 0, candidates: (n_groups * s.x.len()) as u64 })
        })
        .collect();
    let mut g = vec![0.0; points.len()];
    let mut work = Work::default();
    let mut pos = 0usize;
    for (vals, w) in per_block {
        for v in vals {
            g[grid.ids[pos] as usize] = v;
            pos += 1;
        }
        work.exact_vertices += w.exact_vertices;
        work.candidates += w.candidates;
    }
    (g, work)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::saliency::levels::gaussian_means;

    /// A wavy sheet of `n` x `n` points with curvature-like values.
    fn sheet(n: usize, jitter: f64) -> (Vec<DVec3>, Vec<f64>) {
        let mut p = Vec::new();
        let mut h = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let r = crate::util::rng::unit_f64(crate::util::rng::splitmix64((j * n + i) as u64)) - 0.5;
                let (x, y) = (i as f64 / n as f64 + jitter * r / n as f64, j as f64 / n as f64);
                p.push(DVec3::new(x, y, 0.1 * (6.0 * x).sin() * (4.0 * y).cos()));
                h.push((6.0 * x).sin() * (4.0 * y).cos() + 0.3 * (17.0 * y).sin());
            }
        }
        (p, h)
    }

    #[test]
    fn sparse_points_are_summed_exactly() {
        // Sigma below the spacing: every block is cheaper exact, so the result is the exact
        // sum to f32 rounding.
        let (p, h) = sheet(30, 0.3);
        let sigmas = [0.02, 0.03];
        let exact = gaussian_means(&p, &h, &sigmas);
        let (approx, work) = clustered_means_with(&p, &h, &sigmas, BETA, GROUP);
        assert!(work.iter().all(|w| w.exact_vertices == p.len()), "{work:?}");
        for (a, e) in approx.iter().zip(&exact) {
            assert!((a - e).abs() < 1e-5, "{a} vs {e}");
        }
    }

    #[test]
    fn dense_points_are_clustered_and_close() {
        let (p, h) = sheet(160, 0.5);
        let sigmas = [0.04, 0.08];
        let exact = gaussian_means(&p, &h, &sigmas);
        let (approx, work) = clustered_means_with(&p, &h, &sigmas, BETA, GROUP);
        assert!(work.iter().all(|w| w.exact_vertices < p.len() / 2), "{work:?}");
        let range = h.iter().cloned().fold(0.0f64, |m, x| m.max(x.abs()));
        let mean = approx.iter().zip(&exact).map(|(a, e)| (a - e).abs()).sum::<f64>() / exact.len() as f64;
        let max = approx.iter().zip(&exact).map(|(a, e)| (a - e).abs()).fold(0.0, f64::max);
        assert!(mean < 0.01 * range && max < 0.1 * range, "mean {mean} max {max} (range {range})");
    }

    #[test]
    fn handles_degenerate_inputs() {
        assert!(clustered_means(&[], &[], &[1.0]).is_empty());
        // All points at one place; one point; a sigma far below the extent.
        let same = vec![DVec3::splat(2.0); 50];
        let h: Vec<f64> = (0..50).map(|i| i as f64).collect();
        let g = clustered_means(&same, &h, &[0.5, 1.0]);
        assert!(g.iter().all(|x| (x - 24.5).abs() < 1e-3), "{g:?}");
        assert_eq!(clustered_means(&[DVec3::ONE], &[3.0], &[0.1]), vec![3.0]);
        let far = vec![DVec3::ZERO, DVec3::new(1e6, 0.0, 0.0)];
        let g = clustered_means(&far, &[1.0, 2.0], &[1e-3]);
        assert!(g.iter().all(|x| x.is_finite()), "{g:?}");
    }
}
