//! Step 1: the label image cleaned: connected components, specks and thin parts merged away.

use super::BACKGROUND;
use crate::facets::planes::root;
use crate::util::grid::Grid;

/// Connected components (4-neighbourhood, equal values) of `labels`: component id per pixel
/// and each component's (value, area). Numbered in scan order of each component's first
/// pixel, so deterministic.
///
/// By runs: each row's runs of equal values are joined (union-find) to the
/// runs of the row above they touch with the same value, then numbered in scan order of their
/// first run, which holds the component's first pixel: the numbering a flood fill started at
/// each unvisited pixel in scan order gives (`components_by_flood`, the tests' reference), at
/// a cost in runs, not pixels.
pub(super) fn components(labels: &[u32], w: usize, h: usize) -> (Vec<u32>, Vec<(u32, usize)>) {
    if w == 0 || h == 0 {
        return (Vec::new(), Vec::new());
    }
    // Runs (start pixel, end pixel exclusive, value) in scan order; each row's first run index.
    let mut runs: Vec<(usize, usize, u32)> = Vec::new();
    let mut row_start = Vec::with_capacity(h + 1);
    for y in 0..h {
        row_start.push(runs.len());
        let row = &labels[y * w..(y + 1) * w];
        let mut x0 = 0;
        for x in 1..=w {
            if x == w || row[x] != row[x0] {
                runs.push((y * w + x0, y * w + x, row[x0]));
                x0 = x;
            }
        }
    }
    row_start.push(runs.len());
    let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
    for y in 1..h {
        let (above, here) = (row_start[y - 1]..row_start[y], row_start[y]..row_start[y + 1]);
        let mut k = above.start;
        for r in here {
            let (a0, a1, v) = runs[r];
            let (x0, x1) = (a0 - y * w, a1 - y * w);
            // Runs above overlapping [x0, x1): advance past those ending at or before x0.
            while k < above.end && runs[k].1 - (y - 1) * w <= x0 {
                k += 1;
            }
            let mut j = k;
            while j < above.end && runs[j].0 - (y - 1) * w < x1 {
                if runs[j].2 == v {
                    let (ra, rb) = (root(&mut parent, r as u32), root(&mut parent, j as u32));
                    if ra != rb {
                        // The lower index stays the root: no order matters for the numbering,
                        // which reads roots only.
                        let (lo, hi) = (ra.min(rb), ra.max(rb));
                        parent[hi as usize] = lo;
                    }
                }
                j += 1;
            }
        }
    }
    let mut id_of_root = vec![u32::MAX; runs.len()];
    let mut info: Vec<(u32, usize)> = Vec::new();
    let mut comp = vec![0u32; labels.len()];
    for (r, &(a, b, v)) in runs.iter().enumerate() {
        let root = root(&mut parent, r as u32) as usize;
        if id_of_root[root] == u32::MAX {
            id_of_root[root] = info.len() as u32;
            info.push((v, 0));
        }
        let id = id_of_root[root];
        info[id as usize].1 += b - a;
        comp[a..b].fill(id);
    }
    (comp, info)
}

/// Merges every component smaller than `min_area` pixels into the neighbouring value it
/// touches most (ties: the lower value), so specks and pinholes make no plane of their own;
/// and every component thinner than `min_width` pixels on average (twice its area over its
/// border with other components) whose most touched neighbour is an object, not the
/// background: a window's frame, a rim, a seam between two parts is painted with the part it
/// borders most, instead of as a strip between two outlines a few pixels apart (a sliver of a
/// plane, and junctions every few pixels along it). A thin part against the background (a
/// pole, a stem) keeps its outline.
pub fn clean_labels(labels: &mut [u32], w: usize, h: usize, min_area: usize, min_width: f64) {
    if min_area <= 1 && min_width <= 0.0 {
        return;
    }
    let grid = Grid { width: w, height: h };
    let (comp, info) = components(labels, w, h);
    // Each component's border with other components, in pixel edges.
    let mut border = vec![0usize; info.len()];
    if min_width > 0.0 {
        for y in 0..h {
            for x in 0..w {
                let c = comp[y * w + x] as usize;
                for j in
                    [(x + 1 < w).then(|| y * w + x + 1), (y + 1 < h).then(|| (y + 1) * w + x)].into_iter().flatten()
                {
                    let d = comp[j] as usize;
                    if d != c {
                        border[c] += 1;
                        border[d] += 1;
                    }
                }
            }
        }
    }
    let small: Vec<bool> = info.iter().map(|&(_, a)| a < min_area).collect();
    let thin: Vec<bool> =
        info.iter().zip(&border).map(|(&(_, a), &b)| b > 0 && 2.0 * a as f64 / (b as f64) < min_width).collect();
    if !small.contains(&true) && !thin.contains(&true) {
        return;
    }
    // For each small or thin component, count the neighbouring pixels of other values.
    let mut touches: Vec<Vec<(u32, u32)>> = vec![Vec::new(); info.len()];
    for i in 0..labels.len() {
        let c = comp[i] as usize;
        if !small[c] && !thin[c] {
            continue;
        }
        let mut count = |j: usize| {
            let v = labels[j];
            if comp[j] as usize != c {
                let t = &mut touches[c];
                match t.iter_mut().find(|e| e.0 == v) {
                    Some(e) => e.1 += 1,
                    None => t.push((v, 1)),
                }
            }
        };
        grid.neighbours4(i).for_each(&mut count);
    }
    let target: Vec<Option<u32>> = touches
        .iter()
        .enumerate()
        .map(|(c, t)| {
            let most = t.iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))).map(|e| e.0)?;
            (small[c] || most != BACKGROUND).then_some(most)
        })
        .collect();
    for i in 0..labels.len() {
        if let Some(v) = target[comp[i] as usize] {
            labels[i] = v;
        }
    }
}
