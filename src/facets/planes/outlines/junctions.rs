//! Step 3: the junctions where three labels meet, at which shared outlines part.

use glam::DVec2;
use rayon::prelude::*;

use super::trace::DIRS;
use crate::facets::planes::root;

/// The junctions of a label image (objects' ids, `BACKGROUND`): the lattice vertices where
/// three or more labels meet, the image's outside counting as one, and the saddles (two labels
/// touching only at the corner). Two layers' rings that run together (an object's outline and
/// the outline of all geometry, along the object's edge against the background) part only at
/// a junction, where a third label begins, so a ring simplified between its junctions
/// (`simplify_between`) gives every stretch two layers share the same edges in both.
///
/// Junctions joined by a boundary shorter than `reach` lattice steps are one point (a tight
/// cluster where several objects meet): kept apart, each would pin an edge too short to read
/// as a straight stroke (runs of at least 1% of the diagonal), which no layer could
/// merge away. Joined shortest boundary first, while the group's box stays within `reach`.
pub struct Junctions {
    /// The lattice's width (image width + 1).
    pub(super) stride: usize,
    /// Junctions a boundary of at most this many lattice steps apart are one group.
    pub(super) reach: f64,
    /// Junction vertices (y * stride + x), ascending.
    pub(super) at: Vec<usize>,
    /// Each junction's group.
    pub(super) group: Vec<u32>,
    /// Each group's point: the mean of its junctions.
    pub(super) point: Vec<DVec2>,
}

/// The labels around lattice vertex (x, y) (pixels up-left, up-right, down-left,
/// down-right), None outside the image.
pub(super) fn around(labels: &[u32], w: usize, h: usize, x: i64, y: i64) -> [Option<u32>; 4] {
    let at = |px: i64, py: i64| {
        (px >= 0 && py >= 0 && (px as usize) < w && (py as usize) < h).then(|| labels[py as usize * w + px as usize])
    };
    [at(x - 1, y - 1), at(x, y - 1), at(x - 1, y), at(x, y)]
}

impl Junctions {
    pub fn new(labels: &[u32], w: usize, h: usize, reach: f64) -> Junctions {
        let stride = w + 1;
        let is_junction = |x: i64, y: i64| {
            // Inside the image most vertices have one label around them: settled by four reads.
            if x > 0 && y > 0 && (x as usize) < w && (y as usize) < h {
                let (i, j) = ((y as usize - 1) * w + x as usize, y as usize * w + x as usize);
                let l = labels[i];
                if labels[i - 1] == l && labels[j - 1] == l && labels[j] == l {
                    return false;
                }
            }
            let a = around(labels, w, h, x, y);
            let distinct = (0..4).filter(|&i| !a[..i].contains(&a[i])).count();
            distinct >= 3 || (distinct == 2 && a[0] == a[3] && a[1] == a[2])
        };
        let at: Vec<usize> = (0..=h)
            .into_par_iter()
            .flat_map_iter(|y| (0..=w).filter(move |&x| is_junction(x as i64, y as i64)).map(move |x| y * stride + x))
            .collect();
        let index = |x: i64, y: i64| at.binary_search(&(y as usize * stride + x as usize)).ok();
        // Boundaries (between two labels) from each junction, walked up to `reach` steps: the
        // short ones joining two junctions, (steps, from, to) in a deterministic order.
        let steps = reach.floor().max(0.0) as usize;
        let boundary = |x: i64, y: i64, d: usize| {
            let a = around(labels, w, h, x, y);
            // Right: between up-right and down-right; down: down-left and down-right; left:
            // up-left and down-left; up: up-left and up-right.
            match d {
                0 => a[1] != a[3],
                1 => a[2] != a[3],
                2 => a[0] != a[2],
                _ => a[0] != a[1],
            }
        };
        let mut joins: Vec<(usize, u32, u32)> = at
            .par_iter()
            .enumerate()
            .flat_map_iter(|(k, &v)| {
                let (x0, y0) = ((v % stride) as i64, (v / stride) as i64);
                (0..4).filter_map(move |d0| {
                    if !boundary(x0, y0, d0) {
                        return None;
                    }
                    let (mut x, mut y, mut d) = (x0, y0, d0);
                    for n in 1..=steps {
                        x += DIRS[d].0;
                        y += DIRS[d].1;
                        if let Some(j) = index(x, y) {
                            return (j != k).then_some((n, k as u32, j as u32));
                        }
                        // Not a junction: exactly one other boundary edge leaves this vertex.
                        let back = (d + 2) % 4;
                        d = (0..4).find(|&e| e != back && boundary(x, y, e))?;
                    }
                    None
                })
            })
            .collect();
        joins.sort_unstable();
        let mut parent: Vec<u32> = (0..at.len() as u32).collect();
        let corner = |k: usize| DVec2::new((at[k] % stride) as f64, (at[k] / stride) as f64);
        let mut boxes: Vec<(DVec2, DVec2)> = (0..at.len()).map(|k| (corner(k), corner(k))).collect();
        for &(_, a, b) in &joins {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            if ra == rb {
                continue;
            }
            let (lo, hi) =
                (boxes[ra as usize].0.min(boxes[rb as usize].0), boxes[ra as usize].1.max(boxes[rb as usize].1));
            if (hi - lo).max_element() > reach {
                continue;
            }
            let (keep, gone) = (ra.min(rb), ra.max(rb));
            parent[gone as usize] = keep;
            boxes[keep as usize] = (lo, hi);
        }
        // Groups numbered by their first junction; each point the mean of its junctions.
        let mut group = vec![u32::MAX; at.len()];
        let (mut sum, mut count): (Vec<DVec2>, Vec<f64>) = (Vec::new(), Vec::new());
        for k in 0..at.len() {
            let r = root(&mut parent, k as u32) as usize;
            if group[r] == u32::MAX {
                group[r] = sum.len() as u32;
                sum.push(DVec2::ZERO);
                count.push(0.0);
            }
            let g = group[r];
            group[k] = g;
            sum[g as usize] += corner(k);
            count[g as usize] += 1.0;
        }
        let point = sum.iter().zip(&count).map(|(s, c)| *s / *c).collect();
        Junctions { stride, reach, at, group, point }
    }

    /// The group of the junction at lattice vertex (x, y), if it is one.
    pub(super) fn group_at(&self, x: i64, y: i64) -> Option<u32> {
        self.at.binary_search(&(y as usize * self.stride + x as usize)).ok().map(|k| self.group[k])
    }
}
