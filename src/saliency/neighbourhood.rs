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

/// Points bucketed into cubic cells of side `cell`.
pub struct Grid {
    cell: f64,
    origin: DVec3,
    /// Point ids sorted by (cell key, id).
    ids: Vec<u32>,
    /// (key, start, end) ranges into `ids`, sorted by key.
    cells: Vec<(u64, u32, u32)>,
    index: HashMap<u64, u32>,
}

const BITS: u32 = 21;
const MASK: i64 = (1 << BITS) - 1;

fn pack(c: [i64; 3]) -> u64 {
    ((c[0] & MASK) as u64) << (2 * BITS) | ((c[1] & MASK) as u64) << BITS | (c[2] & MASK) as u64
}

impl Grid {
    /// Buckets `points` into cells of side `cell` (> 0), coarsened if the bounds would need
    /// more than 2^20 cells per axis.
    pub fn new(points: &[DVec3], cell: f64) -> Grid {
        let (lo, hi) = points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), p| (l.min(*p), h.max(*p)));
        let extent = if points.is_empty() { 0.0 } else { (hi - lo).max_element() };
        let cell = cell.max(extent / (1u64 << (BITS - 1)) as f64).max(f64::MIN_POSITIVE);
        let origin = if points.is_empty() { DVec3::ZERO } else { lo };
        let mut grid = Grid { cell, origin, ids: Vec::new(), cells: Vec::new(), index: HashMap::new() };
        let mut keyed: Vec<(u64, u32)> = points.iter().enumerate().map(|(i, p)| (grid.key(*p), i as u32)).collect();
        keyed.sort_unstable();
        grid.ids = keyed.iter().map(|k| k.1).collect();
        let mut start = 0usize;
        for i in 1..=keyed.len() {
            if i == keyed.len() || keyed[i].0 != keyed[start].0 {
                grid.index.insert(keyed[start].0, grid.cells.len() as u32);
                grid.cells.push((keyed[start].0, start as u32, i as u32));
                start = i;
            }
        }
        grid
    }

    pub fn cell_size(&self) -> f64 {
        self.cell
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
                    let q = [base[0] + dx, base[1] + dy, base[2] + dz];
                    if q.iter().any(|&x| !(0..=MASK).contains(&x)) {
                        continue;
                    }
                    if let Some(&ci) = self.index.get(&pack(q)) {
                        f(ci as usize);
                    }
                }
            }
        }
    }
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
