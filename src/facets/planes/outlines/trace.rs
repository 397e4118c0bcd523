//! Step 2: a layer's mask traced into closed rings on the pixel-corner lattice.

use std::collections::VecDeque;

use glam::DVec2;
use rayon::prelude::*;

use crate::util::grid::Grid;

/// Keeps, of `mask`, the 4-connected components that contain a pixel where `seed` is true.
pub(super) fn keep_seeded(mask: &mut [bool], w: usize, h: usize, seed: impl Fn(usize) -> bool) {
    let grid = Grid { width: w, height: h };
    let mut keep = vec![false; mask.len()];
    let mut queue: VecDeque<usize> = (0..mask.len()).filter(|&i| mask[i] && seed(i)).collect();
    for &i in &queue {
        keep[i] = true;
    }
    while let Some(i) = queue.pop_front() {
        let mut visit = |j: usize| {
            if mask[j] && !keep[j] {
                keep[j] = true;
                queue.push_back(j);
            }
        };
        grid.neighbours4(i).for_each(&mut visit);
    }
    mask.copy_from_slice(&keep);
}

/// The smallest box (x0, y0, x1, y1, inclusive) holding every pixel `inside` of a w x h image,
/// None when there is none (rows in parallel).
pub(super) fn bounding_box(
    w: usize,
    h: usize,
    inside: &(dyn Fn(usize) -> bool + Sync),
) -> Option<(usize, usize, usize, usize)> {
    (0..h)
        .into_par_iter()
        .filter_map(|y| {
            let x0 = (0..w).find(|&x| inside(y * w + x))?;
            let x1 = (x0..w).rev().find(|&x| inside(y * w + x))?;
            Some((x0, y, x1, y))
        })
        .reduce_with(|a, b| (a.0.min(b.0), a.1.min(b.1), a.2.max(b.2), a.3.max(b.3)))
}

/// `trace` of the mask of the pixels `inside` (with `seed`: only its 4-connected components
/// holding a pixel where `seed` is true, `keep_seeded`), made, filled and walked within the
/// mask's bounding box alone (an object's layer is a part of the image). The
/// same rings as over the whole image: outside the box the lattice has no edge, and inside it
/// the vertices come in the same order (rows, then columns); the points are moved back by the
/// box's corner (whole numbers: exact).
pub(super) fn trace_within_box(
    w: usize,
    h: usize,
    inside: &(dyn Fn(usize) -> bool + Sync),
    seed: Option<&(dyn Fn(usize) -> bool + Sync)>,
) -> Vec<Vec<DVec2>> {
    let Some((x0, y0, x1, y1)) = bounding_box(w, h, inside) else { return Vec::new() };
    let (bw, bh) = (x1 - x0 + 1, y1 - y0 + 1);
    let at = |k: usize| (y0 + k / bw) * w + x0 + k % bw;
    let mut mask: Vec<bool> = (0..bw * bh).into_par_iter().map(|k| inside(at(k))).collect();
    if let Some(seed) = seed {
        keep_seeded(&mut mask, bw, bh, |k| seed(at(k)));
    }
    let corner = DVec2::new(x0 as f64, y0 as f64);
    let mut rings = trace(&mask, bw, bh);
    rings.iter_mut().flatten().for_each(|p| *p += corner);
    rings
}

// Directions on the pixel-corner lattice (y down): right, down, left, up.
pub(super) const DIRS: [(i64, i64); 4] = [(1, 0), (0, 1), (-1, 0), (0, -1)];

/// The boundary of `mask` as closed rings of lattice points (corners only), the mask on the
/// right of the direction of travel (y down): outer boundaries run clockwise on screen, holes
/// anticlockwise. At a saddle (two mask pixels touching at a corner) the walk turns right,
/// so diagonal neighbours stay separate rings (4-connectivity).
pub fn trace(mask: &[bool], w: usize, h: usize) -> Vec<Vec<DVec2>> {
    let vw = w + 1;
    let at =
        |x: i64, y: i64| x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h && mask[y as usize * w + x as usize];
    // Outgoing boundary edges per lattice vertex, one bit per direction, each vertex from
    // the four pixels around it (rows of vertices in parallel): the edge
    // going right along the top of pixel (x, y), down the right of (x - 1, y), left along the
    // bottom of (x - 1, y - 1) and up the left of (x, y - 1), each where the mask ends.
    let mut out = vec![0u8; vw * (h + 1)];
    out.par_chunks_mut(vw).enumerate().for_each(|(y, row)| lattice_row(&at, y, row));
    let mut rings = Vec::new();
    for start in 0..out.len() {
        while out[start] != 0 {
            let d0 = out[start].trailing_zeros() as usize;
            let (sx, sy) = ((start % vw) as i64, (start / vw) as i64);
            let (mut x, mut y, mut d) = (sx, sy, d0);
            let mut ring = Vec::new();
            let mut prev_d = usize::MAX;
            loop {
                out[y as usize * vw + x as usize] &= !(1 << d);
                if d != prev_d {
                    ring.push(DVec2::new(x as f64, y as f64));
                }
                prev_d = d;
                x += DIRS[d].0;
                y += DIRS[d].1;
                let mut bits = out[y as usize * vw + x as usize];
                let home = (x, y) == (sx, sy);
                if home {
                    bits |= 1 << d0;
                }
                // Prefer a right turn, then straight on, then a left turn.
                let (right, left) = ((d + 1) % 4, (d + 3) % 4);
                let next = [right, d, left].into_iter().find(|&k| bits & (1 << k) != 0);
                match next {
                    Some(k) if home && k == d0 => break,
                    Some(k) => d = k,
                    None => break, // cannot happen on a closed boundary; stop safely
                }
            }
            if ring.len() >= 4 {
                rings.push(ring);
            }
        }
    }
    rings
}

/// Row `y` of `trace`'s lattice vertices: each vertex's outgoing boundary edges from the four
/// pixels around it (`at(x, y)`: pixel in the mask): right along the top of pixel (x, y), down
/// the right of (x - 1, y), left along the bottom of (x - 1, y - 1), up the left of (x, y - 1),
/// each where the mask ends; the mask on the right of the direction of travel.
pub(super) fn lattice_row(at: &(impl Fn(i64, i64) -> bool + Sync), y: usize, row: &mut [u8]) {
    let y = y as i64;
    for (x, bits) in row.iter_mut().enumerate() {
        let x = x as i64;
        let (here, left, up, up_left) = (at(x, y), at(x - 1, y), at(x, y - 1), at(x - 1, y - 1));
        *bits = (here && !up) as u8
            | ((left && !here) as u8) << 1
            | ((up_left && !left) as u8) << 2
            | ((up && !up_left) as u8) << 3;
    }
}
