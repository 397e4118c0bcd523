//! Fixed-radius neighbourhoods through a uniform grid, queried a whole cell at a time.
//!
//! Why hand-written rather than a k-d tree crate: saliency asks, for every vertex, for all
//! vertices within one radius. Vertices of one grid cell share their candidate list, so it is
//! gathered once per cell into contiguous arrays and the inner loop is a flat scan; a per-point
//! tree query (kiddo, rstar) repeats the traversal for every vertex and returns unordered
//! results we would have to re-sort for determinism. Candidates come in a fixed order (cell
//! offset, then vertex id), so every per-vertex sum is the same on any thread count.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

/// Points bucketed into cubic cells of side `cell`.
pub struct Grid {
    cell: f64,
    origin: DVec3,
    /// Point ids sorted by (cell key, id).
    ids: Vec<u32>,
    /// (key, start, end) ranges into `ids`, sorted by key.
    cells: Vec<(u64, u32, u32)>,
    index: Index,
}

/// Occupied cell by coordinates: a dense array over the bounding box when it has at most
/// `DENSE_MAX` cells (always, for saliency's radii, which are at least 1.2% of the diagonal:
/// lookups are then one load), else a hash map.
enum Index {
    Dense { dims: [i64; 3], cells: Vec<u32> },
    Hash(HashMap<u64, u32>),
}

const DENSE_MAX: u64 = 1 << 23;

const BITS: u32 = 21;
const MASK: i64 = (1 << BITS) - 1;

fn pack(c: [i64; 3]) -> u64 {
    ((c[0] & MASK) as u64) << (2 * BITS) | ((c[1] & MASK) as u64) << BITS | (c[2] & MASK) as u64
}

impl Grid {
    /// Buckets `points` into cells of side `cell` (> 0), coarsened if the bounds would need
    /// more than 2^20 cells per axis.
    pub fn new(points: &[DVec3], cell: f64) -> Grid {
        // In parallel: saliency builds one grid per level over the same points, and these
        // passes ran on one core while the other idled (minima and maxima are exact, so the
        // same bounds on any thread count).
        let (lo, hi) = points
            .par_iter()
            .fold(|| (DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), p| (l.min(*p), h.max(*p)))
            .reduce(|| (DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), (c, d)| (a.min(c), b.max(d)));
        let extent = if points.is_empty() { 0.0 } else { (hi - lo).max_element() };
        let cell = cell.max(extent / (1u64 << (BITS - 1)) as f64).max(f64::MIN_POSITIVE);
        let origin = if points.is_empty() { DVec3::ZERO } else { lo };
        let dims = if points.is_empty() { [1; 3] } else { ((hi - lo) / cell).floor().to_array().map(|d| d as i64 + 1) };
        let index = if dims.iter().map(|&d| d as u64).product::<u64>() <= DENSE_MAX {
            Index::Dense { dims, cells: vec![u32::MAX; (dims[0] * dims[1] * dims[2]) as usize] }
        } else {
            Index::Hash(HashMap::new())
        };
        let mut grid = Grid { cell, origin, ids: Vec::new(), cells: Vec::new(), index };
        let keyed: Vec<(u64, u32)> = match &grid.index {
            // The dense index orders cells as their packed keys do (x, then y, then z).
            Index::Dense { dims, cells } => {
                let lin: Vec<u32> = points
                    .par_iter()
                    .map(|p| {
                        let c = grid.coords(*p);
                        ((c[0] * dims[1] + c[1]) * dims[2] + c[2]) as u32
                    })
                    .collect();
                bucket_order(&lin, cells.len()).into_par_iter().map(|i| (grid.key(points[i as usize]), i)).collect()
            }
            Index::Hash(_) => {
                let mut keyed: Vec<(u64, u32)> =
                    points.par_iter().enumerate().map(|(i, p)| (grid.key(*p), i as u32)).collect();
                keyed.par_sort_unstable();
                keyed
            }
        };
        grid.ids = keyed.par_iter().map(|k| k.1).collect();
        // Each cell's first point, found in parallel; then one entry per cell.
        let starts: Vec<u32> = (0..keyed.len())
            .into_par_iter()
            .filter(|&i| i == 0 || keyed[i].0 != keyed[i - 1].0)
            .map(|i| i as u32)
            .collect();
        grid.cells = starts
            .par_iter()
            .enumerate()
            .map(|(c, &s)| {
                let end = starts.get(c + 1).map_or(keyed.len() as u32, |&e| e);
                (keyed[s as usize].0, s, end)
            })
            .collect();
        for (id, &(key, _, _)) in grid.cells.iter().enumerate() {
            let c = grid.unpack(key);
            match &mut grid.index {
                Index::Dense { dims, cells } => cells[((c[0] * dims[1] + c[1]) * dims[2] + c[2]) as usize] = id as u32,
                Index::Hash(map) => {
                    map.insert(key, id as u32);
                }
            }
        }
        grid
    }

    /// The occupied cell at coordinates `c`, if any.
    fn lookup(&self, c: [i64; 3]) -> Option<usize> {
        match &self.index {
            Index::Dense { dims, cells } => {
                if (0..3).any(|a| c[a] < 0 || c[a] >= dims[a]) {
                    return None;
                }
                let v = cells[((c[0] * dims[1] + c[1]) * dims[2] + c[2]) as usize];
                (v != u32::MAX).then_some(v as usize)
            }
            Index::Hash(map) => {
                if c.iter().any(|&x| !(0..=MASK).contains(&x)) {
                    return None;
                }
                map.get(&pack(c)).map(|&v| v as usize)
            }
        }
    }

    fn coords(&self, p: DVec3) -> [i64; 3] {
        let c = ((p - self.origin) / self.cell).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    }

    fn key(&self, p: DVec3) -> u64 {
        pack(self.coords(p))
    }

    fn unpack(&self, key: u64) -> [i64; 3] {
        [(key >> (2 * BITS)) as i64 & MASK, (key >> BITS) as i64 & MASK, key as i64 & MASK]
    }

    /// Number of occupied cells.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    /// Point ids of occupied cell `c` (0..cell_count), ascending.
    pub fn cell_points(&self, c: usize) -> &[u32] {
        let (_, s, e) = self.cells[c];
        &self.ids[s as usize..e as usize]
    }

    /// Appends to `out` the ids of every point in cells that may hold a point within `radius`
    /// of some point of cell `c` (cells whose box lies within `radius` of `c`'s box), in a
    /// fixed order: by cell offset, then ascending id.
    pub fn candidates(&self, c: usize, radius: f64, out: &mut Vec<u32>) {
        self.for_near_cells(c, radius, |ci| {
            let (_, s, e) = self.cells[ci];
            out.extend_from_slice(&self.ids[s as usize..e as usize]);
        });
    }

    fn for_near_cells(&self, c: usize, radius: f64, mut f: impl FnMut(usize)) {
        let base = self.unpack(self.cells[c].0);
        let m = (radius / self.cell).ceil() as i64;
        let r_cells = radius / self.cell;
        // Gap between two cells' boxes along an axis, in cells.
        let gap = |d: i64| (d.abs() - 1).max(0) as f64;
        for dx in -m..=m {
            for dy in -m..=m {
                for dz in -m..=m {
                    let g2 = gap(dx).powi(2) + gap(dy).powi(2) + gap(dz).powi(2);
                    if g2 >= r_cells * r_cells && (dx, dy, dz) != (0, 0, 0) {
                        continue;
                    }
                    if let Some(ci) = self.lookup([base[0] + dx, base[1] + dy, base[2] + dz]) {
                        f(ci);
                    }
                }
            }
        }
    }

    /// Candidate pairs the exact sums visit with this grid at `radius`: for every occupied cell,
    /// its points times the points of the cells `candidates` returns. Counted, not estimated,
    /// in one pass over the occupied cells (no distances).
    pub fn candidate_pairs(&self, radius: f64) -> u64 {
        (0..self.cells.len())
            .into_par_iter()
            .map(|c| {
                let mut near = 0u64;
                self.for_near_cells(c, radius, |ci| near += (self.cells[ci].2 - self.cells[ci].1) as u64);
                near * (self.cells[c].2 - self.cells[c].1) as u64
            })
            .sum()
    }
}

/// Positions 0..n ordered by `bucket[i]` (each < `buckets`), ties by position: a counting sort,
/// O(n + buckets), a few times faster than a comparison sort of (bucket, i) pairs.
pub fn bucket_order(bucket: &[u32], buckets: usize) -> Vec<u32> {
    let mut start = vec![0u32; buckets + 1];
    for &b in bucket {
        start[b as usize + 1] += 1;
    }
    for i in 0..buckets {
        start[i + 1] += start[i];
    }
    let mut out = vec![0u32; bucket.len()];
    for (i, &b) in bucket.iter().enumerate() {
        out[start[b as usize] as usize] = i as u32;
        start[b as usize] += 1;
    }
    out
}

/// Squared distance, computed one way everywhere (the brute-force oracle uses it too) so the
/// strict `d < r` tests decide identically.
#[inline(always)]
pub fn dist2(a: DVec3, b: DVec3) -> f64 {
    let d = a - b;
    d.x * d.x + d.y * d.y + d.z * d.z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_cover_every_neighbour_once() {
        let mut pts = Vec::new();
        let mut h = 1u64;
        for _ in 0..600 {
            let mut r = || {
                h = crate::util::rng::splitmix64(h);
                crate::util::rng::unit_f64(h) * 3.0 - 1.0
            };
            pts.push(DVec3::new(r(), r(), r() * 0.2));
        }
        for (cell, radius) in [(0.3, 0.3), (0.1, 0.35), (0.5, 0.2)] {
            let g = Grid::new(&pts, cell);
            let mut seen = vec![0u32; pts.len()];
            let mut cand = Vec::new();
            for c in 0..g.cell_count() {
                cand.clear();
                g.candidates(c, radius, &mut cand);
                let mut sorted = cand.clone();
                sorted.sort_unstable();
                sorted.dedup();
                assert_eq!(sorted.len(), cand.len(), "duplicate candidates");
                for &i in g.cell_points(c) {
                    seen[i as usize] += 1;
                    for j in 0..pts.len() {
                        if dist2(pts[i as usize], pts[j]) < radius * radius {
                            assert!(sorted.binary_search(&(j as u32)).is_ok(), "missed neighbour");
                        }
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1));
        }
    }
}
