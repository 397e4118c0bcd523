//! Voronoi faceting (thesis 4.3.1): k points stratified over m grid cells,
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
/// pixels: x w, y h); ties go to the lower index. Exact, and bounded in time whatever the
/// sites (clustered, coincident, all in one corner): a k-d tree searched from the previous
/// pixel's site, so a pixel visits a few nodes. (A bucket grid took O(pixels x sites) for
/// sites in one cell: 65,536 of them took minutes.)
pub fn nearest_sites(sites: &[[f64; 2]], width: u32, height: u32, ids: &mut [u32]) {
    let (w, h) = (width as f64, height as f64);
    let pts: Vec<[f64; 2]> = sites.iter().map(|s| [s[0] * w, s[1] * h]).collect();
    let tree = KdTree::new(&pts);
    let wu = width as usize;
    ids.par_chunks_mut(wu).enumerate().for_each(|(y, row)| {
        let py = y as f64 + 0.5;
        let mut stack = Vec::with_capacity(64);
        let mut hint = u32::MAX;
        for (x, id) in row.iter_mut().enumerate() {
            hint = tree.nearest([x as f64 + 0.5, py], hint, &mut stack);
            *id = hint;
        }
    });
}

/// A k-d tree over the sites for exact nearest-site queries with the lower-index tie rule.
struct KdTree<'p> {
    pts: &'p [[f64; 2]],
    /// Site indices, grouped by leaf.
    order: Vec<u32>,
    nodes: Vec<KdNode>,
}

struct KdNode {
    lo: [f64; 2],
    hi: [f64; 2],
    /// `order[start..end]` when a leaf.
    start: u32,
    end: u32,
    /// The lowest site index below this node (a tie is only searched for where it can win).
    min_index: u32,
    /// Children (0 for a leaf: node 0 is the root, never a child).
    left: u32,
    right: u32,
}

const LEAF: usize = 8;

impl<'p> KdTree<'p> {
    fn new(pts: &'p [[f64; 2]]) -> Self {
        // Coincident sites: only the lowest index can ever be nearest.
        let mut order: Vec<u32> = (0..pts.len() as u32).collect();
        order.sort_by(|&a, &b| {
            let (p, q) = (pts[a as usize], pts[b as usize]);
            p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1])).then(a.cmp(&b))
        });
        order.dedup_by(|b, a| pts[*a as usize] == pts[*b as usize]);
        let mut tree = KdTree { pts, order, nodes: Vec::new() };
        if !tree.order.is_empty() {
            let n = tree.order.len();
            tree.build(0, n);
        }
        tree
    }

    fn build(&mut self, start: usize, end: usize) -> u32 {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut min_index = u32::MAX;
        for &i in &self.order[start..end] {
            let p = self.pts[i as usize];
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            min_index = min_index.min(i);
        }
        let me = self.nodes.len() as u32;
        self.nodes.push(KdNode { lo, hi, start: start as u32, end: end as u32, min_index, left: 0, right: 0 });
        if end - start > LEAF {
            let axis = if hi[0] - lo[0] >= hi[1] - lo[1] { 0 } else { 1 };
            let mid = (start + end) / 2;
            let pts = self.pts;
            self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
                pts[a as usize][axis].total_cmp(&pts[b as usize][axis]).then(a.cmp(&b))
            });
            let left = self.build(start, mid);
            let right = self.build(mid, end);
            let node = &mut self.nodes[me as usize];
            (node.left, node.right) = (left, right);
        }
        me
    }

    fn distance(&self, i: u32, q: [f64; 2]) -> f64 {
        let p = self.pts[i as usize];
        (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1])
    }

    /// Squared distance from `q` to a node's box: no site below it is nearer.
    fn box_distance(n: &KdNode, q: [f64; 2]) -> f64 {
        let dx = (n.lo[0] - q[0]).max(q[0] - n.hi[0]).max(0.0);
        let dy = (n.lo[1] - q[1]).max(q[1] - n.hi[1]).max(0.0);
        dx * dx + dy * dy
    }

    /// The nearest site to `q` (lowest index among equals), starting from the bound `hint`
    /// gives (a site index or `u32::MAX`). `u32::MAX` when there is no site.
    fn nearest(&self, q: [f64; 2], hint: u32, stack: &mut Vec<u32>) -> u32 {
        if self.nodes.is_empty() {
            return u32::MAX;
        }
        let mut best = if hint == u32::MAX { (f64::INFINITY, u32::MAX) } else { (self.distance(hint, q), hint) };
        // A node can hold a better site only if its box is nearer, or as near with a lower index.
        let worth = |n: &KdNode, best: (f64, u32)| {
            let d = Self::box_distance(n, q);
            d < best.0 || (d == best.0 && n.min_index < best.1)
        };
        stack.clear();
        stack.push(0);
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k as usize];
            if !worth(n, best) {
                continue;
            }
            if n.left == 0 {
                for &i in &self.order[n.start as usize..n.end as usize] {
                    let d = self.distance(i, q);
                    if d < best.0 || (d == best.0 && i < best.1) {
                        best = (d, i);
                    }
                }
                continue;
            }
            // The nearer child last on the stack: searched first.
            let (l, r) = (&self.nodes[n.left as usize], &self.nodes[n.right as usize]);
            if Self::box_distance(l, q) <= Self::box_distance(r, q) {
                stack.push(n.right);
                stack.push(n.left);
            } else {
                stack.push(n.left);
                stack.push(n.right);
            }
        }
        best.1
    }
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

    #[test]
    fn clustered_and_coincident_sites_take_bounded_time() {
        // 65,536 sites in one pixel, in one corner, and all coincident: each used to take
        // minutes (every pixel scanned every site).
        let n = 65536usize;
        let cluster: Vec<[f64; 2]> =
            (0..n).map(|i| [0.5 + (i % 256) as f64 * 1e-9, 0.5 + (i / 256) as f64 * 1e-9]).collect();
        let corner: Vec<[f64; 2]> = (0..n).map(|i| [(i % 256) as f64 * 1e-5, (i / 256) as f64 * 1e-5]).collect();
        let same = vec![[0.25, 0.75]; n];
        for sites in [cluster, corner, same] {
            let t = std::time::Instant::now();
            let mut ids = vec![0; 400 * 300];
            nearest_sites(&sites, 400, 300, &mut ids);
            assert!(t.elapsed().as_secs_f64() < 20.0, "{:?}", t.elapsed());
            // Spot-check exactness against brute force on a few pixels.
            for &(x, y) in &[(0u32, 0u32), (399, 299), (200, 150), (17, 230)] {
                let q = (x as f64 + 0.5, y as f64 + 0.5);
                let mut b = (f64::INFINITY, 0u32);
                for (i, s) in sites.iter().enumerate() {
                    let (sx, sy) = (s[0] * 400.0, s[1] * 300.0);
                    let d = (sx - q.0) * (sx - q.0) + (sy - q.1) * (sy - q.1);
                    if d < b.0 {
                        b = (d, i as u32);
                    }
                }
                assert_eq!(ids[(y * 400 + x) as usize], b.1, "pixel ({x}, {y})");
            }
        }
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
