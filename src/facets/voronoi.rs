//! Voronoi faceting (SPEC "Faceting", thesis 4.3.1): k points stratified over m grid cells,
//! each pixel in the facet of its nearest point. The nearest point is found through a bucket
//! grid (rings of cells searched outwards until no closer point can exist), not the thesis's
//! O(pixels x k) loop; ties go to the lower point index, so the map is exact and deterministic.

use rayon::prelude::*;

use super::FacetLayout;
use crate::util::rng::rand01;

const STREAM: u64 = 0x0076_6f72_6f6e_6f69; // "voronoi"

/// The thesis's grid: cells of side sqrt(w h / m), `round(w / side)` columns and
/// `round(m / columns)` rows (at least one each). Depends on the aspect ratio only.
pub fn grid(cells: u32, aspect: f64) -> (u32, u32) {
    let m = cells.max(1) as f64;
    // In units where w h = 1: w = sqrt(aspect), h = 1 / sqrt(aspect).
    let side = (1.0 / m).sqrt();
    let gx = ((aspect.sqrt() / side) + 0.49).floor().max(1.0);
    let gy = ((m / gx) + 0.49).floor().max(1.0);
    (gx as u32, gy as u32)
}

/// k sites, stratified: cell j of the grid gets floor(k (j+1) / cells) - floor(k j / cells)
/// points (k / m each when m divides k, as in the thesis), uniform within the cell.
/// Normalised coordinates, so the layout is the same at any resolution of this aspect.
pub fn layout(k: u32, cells: u32, aspect: f64, seed: u64) -> FacetLayout {
    let (gx, gy) = grid(cells, aspect);
    let n = (gx * gy) as u64;
    let mut sites = Vec::with_capacity(k as usize);
    for j in 0..n {
        let count = (k as u64 * (j + 1)) / n - (k as u64 * j) / n;
        let (cx, cy) = ((j % gx as u64) as f64, (j / gx as u64) as f64);
        for _ in 0..count {
            let i = sites.len() as u64;
            let x = (cx + rand01(seed, STREAM, 2 * i)) / gx as f64;
            let y = (cy + rand01(seed, STREAM, 2 * i + 1)) / gy as f64;
            sites.push([x, y]);
        }
    }
    FacetLayout { facet_count: k.max(1), base: None, sites, polygons: Vec::new() }
}

/// Writes into `ids` the index of the site nearest to each pixel centre (sites scaled to
/// pixels: x w, y h). Exact: a bucket grid of about one site per cell, searched in growing
/// square rings until the ring lies farther than the best distance found.
pub fn nearest_sites(sites: &[[f64; 2]], width: u32, height: u32, ids: &mut [u32]) {
    let (w, h) = (width as f64, height as f64);
    let pts: Vec<(f64, f64)> = sites.iter().map(|s| (s[0] * w, s[1] * h)).collect();
    let cell = ((w * h) / pts.len().max(1) as f64).sqrt().max(1.0);
    let gx = ((w / cell).ceil() as usize).max(1);
    let gy = ((h / cell).ceil() as usize).max(1);
    let cell_of = |v: f64, g: usize| ((v / cell).floor().max(0.0) as usize).min(g - 1);
    // Counting sort of the sites into cells (ascending index within a cell).
    let mut start = vec![0usize; gx * gy + 1];
    for p in &pts {
        start[cell_of(p.1, gy) * gx + cell_of(p.0, gx) + 1] += 1;
    }
    for c in 0..gx * gy {
        start[c + 1] += start[c];
    }
    let mut next = start.clone();
    let mut order = vec![0u32; pts.len()];
    for (i, p) in pts.iter().enumerate() {
        let c = cell_of(p.1, gy) * gx + cell_of(p.0, gx);
        order[next[c]] = i as u32;
        next[c] += 1;
    }
    let wu = width as usize;
    ids.par_chunks_mut(wu).enumerate().for_each(|(y, row)| {
        let py = y as f64 + 0.5;
        let cy = cell_of(py, gy) as i64;
        for (x, id) in row.iter_mut().enumerate() {
            let px = x as f64 + 0.5;
            let cx = cell_of(px, gx) as i64;
            let mut best = (f64::INFINITY, u32::MAX);
            let mut r = 0i64;
            loop {
                for yy in (cy - r).max(0)..=(cy + r).min(gy as i64 - 1) {
                    let on_edge_row = yy == cy - r || yy == cy + r;
                    let step = if on_edge_row { 1 } else { (2 * r).max(1) as usize };
                    let mut xx = cx - r;
                    while xx <= cx + r {
                        if xx >= 0 && xx < gx as i64 {
                            let c = yy as usize * gx + xx as usize;
                            for &s in &order[start[c]..start[c + 1]] {
                                let (sx, sy) = pts[s as usize];
                                let d = (sx - px) * (sx - px) + (sy - py) * (sy - py);
                                if d < best.0 || (d == best.0 && s < best.1) {
                                    best = (d, s);
                                }
                            }
                        }
                        xx += step as i64;
                    }
                }
                // Every site outside the searched block is at least this far away.
                let gap = [
                    px - (cx - r) as f64 * cell,
                    (cx + r + 1) as f64 * cell - px,
                    py - (cy - r) as f64 * cell,
                    (cy + r + 1) as f64 * cell - py,
                ];
                let covered = cx - r <= 0 && cy - r <= 0 && cx + r >= gx as i64 - 1 && cy + r >= gy as i64 - 1;
                // Cells outside the grid hold no sites; only the in-grid sides bound the rest.
                let mut margin = f64::INFINITY;
                if cx - r > 0 {
                    margin = margin.min(gap[0]);
                }
                if cx + r < gx as i64 - 1 {
                    margin = margin.min(gap[1]);
                }
                if cy - r > 0 {
                    margin = margin.min(gap[2]);
                }
                if cy + r < gy as i64 - 1 {
                    margin = margin.min(gap[3]);
                }
                if covered || (best.1 != u32::MAX && margin * margin > best.0) {
                    break;
                }
                r += 1;
            }
            *id = best.1;
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute(sites: &[[f64; 2]], w: u32, h: u32) -> Vec<u32> {
        let mut ids = vec![0; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let mut best = (f64::INFINITY, 0u32);
                for (i, s) in sites.iter().enumerate() {
                    let (sx, sy) = (s[0] * w as f64, s[1] * h as f64);
                    let d = (sx - px) * (sx - px) + (sy - py) * (sy - py);
                    if d < best.0 {
                        best = (d, i as u32);
                    }
                }
                ids[(y * w + x) as usize] = best.1;
            }
        }
        ids
    }

    #[test]
    fn thesis_grid_defaults() {
        // 150 points over 15 cells of a 4:3 image: 4 x 4 cells in the thesis's code
        // (round(w / side) = 4.47 -> 4 columns, round(15 / 4) = 3.75 -> 4 rows).
        assert_eq!(grid(15, 4.0 / 3.0), (4, 4));
        assert_eq!(grid(15, 1.0), (4, 4));
        assert_eq!(grid(1, 1.0), (1, 1));
        assert_eq!(grid(4, 16.0), (8, 1));
    }

    #[test]
    fn k_points_stratified_per_cell() {
        let l = layout(150, 15, 1.0, 7);
        assert_eq!(l.sites.len(), 150);
        assert_eq!(l.facet_count, 150);
        let (gx, gy) = grid(15, 1.0);
        let mut per = vec![0; (gx * gy) as usize];
        for s in &l.sites {
            assert!((0.0..1.0).contains(&s[0]) && (0.0..1.0).contains(&s[1]));
            per[((s[1] * gy as f64) as u32 * gx + (s[0] * gx as f64) as u32) as usize] += 1;
        }
        let (lo, hi) = (per.iter().min().unwrap(), per.iter().max().unwrap());
        assert!(hi - lo <= 1, "{per:?}");
        assert_eq!(l, layout(150, 15, 1.0, 7), "seeded");
        assert_ne!(l, layout(150, 15, 1.0, 8));
    }

    #[test]
    fn ties_go_to_the_lower_index() {
        // Two sites mirrored about a pixel-centre column: that column is equidistant.
        let sites = [[0.75, 0.5], [0.25, 0.5], [0.25, 0.5]];
        let mut ids = vec![0; 9 * 3];
        nearest_sites(&sites, 9, 3, &mut ids);
        assert_eq!(ids, brute(&sites, 9, 3));
        // The middle column (x = 4.5) is at 2.25 from both: index 0 wins; 2 never wins over 1.
        assert_eq!(ids[4], 0);
        assert!(!ids.contains(&2));
    }

    proptest! {
        #[test]
        fn bucket_search_equals_brute_force(
            sites in prop::collection::vec((0.0f64..1.0, 0.0f64..1.0), 1..60),
            w in 1u32..40, h in 1u32..40,
        ) {
            let sites: Vec<[f64; 2]> = sites.into_iter().map(|(x, y)| [x, y]).collect();
            let mut ids = vec![0; (w * h) as usize];
            nearest_sites(&sites, w, h, &mut ids);
            prop_assert_eq!(ids, brute(&sites, w, h));
        }

        #[test]
        fn sites_outside_the_image_are_handled(
            sites in prop::collection::vec((-0.5f64..1.5, -0.5f64..1.5), 1..20),
        ) {
            let sites: Vec<[f64; 2]> = sites.into_iter().map(|(x, y)| [x, y]).collect();
            let mut ids = vec![0; 20 * 15];
            nearest_sites(&sites, 20, 15, &mut ids);
            prop_assert_eq!(ids, brute(&sites, 20, 15));
        }
    }
}
