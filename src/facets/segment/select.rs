//! Segment selection, shape fitting and ordering (Segment; thesis 4.3.1 steps
//! 2-4): a segment becomes a facet when its mean saliency reaches its level's threshold; its
//! shape is the quadrilateral through its left-most, top-most, right-most and bottom-most
//! pixels; facets are drawn in ascending mean saliency; uncovered pixels keep their level-1
//! segment.

use rayon::prelude::*;

use crate::facets::{FacetLayout, FacetPolygon, LabelImage};

/// One segment's pixel statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentStats {
    pub area: u64,
    pub saliency_sum: f64,
    /// Extreme pixels (x, y): left-most, top-most, right-most, bottom-most. Ties go round the
    /// clock: the upper of the left-most, the right of the top-most, the lower of the
    /// right-most, the left of the bottom-most, so a rectangle's quad is the rectangle itself.
    pub extremes: [(u32, u32); 4],
}

impl SegmentStats {
    fn empty() -> SegmentStats {
        SegmentStats {
            area: 0,
            saliency_sum: 0.0,
            extremes: [(u32::MAX, u32::MAX), (0, u32::MAX), (0, 0), (u32::MAX, 0)],
        }
    }

    fn add(&mut self, x: u32, y: u32, s: f32) {
        self.area += 1;
        self.saliency_sum += s as f64;
        let [l, t, r, b] = &mut self.extremes;
        if (x, y) < *l {
            *l = (x, y);
        }
        if y < t.1 || (y == t.1 && x > t.0) {
            *t = (x, y);
        }
        if x > r.0 || (x == r.0 && y > r.1) {
            *r = (x, y);
        }
        if y > b.1 || (y == b.1 && x < b.0) {
            *b = (x, y);
        }
    }

    fn merge(&mut self, o: &SegmentStats) {
        if o.area == 0 {
            return;
        }
        if self.area == 0 {
            *self = o.clone();
            return;
        }
        self.area += o.area;
        self.saliency_sum += o.saliency_sum;
        for (k, &(x, y)) in o.extremes.iter().enumerate() {
            let e = &mut self.extremes[k];
            let better = match k {
                0 => (x, y) < *e,
                1 => y < e.1 || (y == e.1 && x > e.0),
                2 => x > e.0 || (x == e.0 && y > e.1),
                _ => y > e.1 || (y == e.1 && x < e.0),
            };
            if better {
                *e = (x, y);
            }
        }
    }

    /// Mean saliency of the segment's pixels (0 for an empty segment).
    pub fn mean_saliency(&self) -> f64 {
        if self.area == 0 { 0.0 } else { self.saliency_sum / self.area as f64 }
    }

    /// The quadrilateral through the extreme pixels, in normalised image coordinates: each
    /// vertex is the extreme pixel's outer corner (top-left of the left-most, top-right of the
    /// top-most, bottom-right of the right-most, bottom-left of the bottom-most), so the quad
    /// covers those pixels. Clockwise on screen (y down); convex, since each vertex is extreme
    /// in one of four directions taken in turn.
    pub fn quad(&self, width: u32, height: u32) -> [[f64; 2]; 4] {
        let (w, h) = (width as f64, height as f64);
        let [l, t, r, b] = self.extremes;
        [
            [l.0 as f64 / w, l.1 as f64 / h],
            [(t.0 + 1) as f64 / w, t.1 as f64 / h],
            [(r.0 + 1) as f64 / w, (r.1 + 1) as f64 / h],
            [b.0 as f64 / w, (b.1 + 1) as f64 / h],
        ]
    }
}

/// Rows per block of the parallel statistics pass (fixed: results do not depend on threads).
const BLOCK_ROWS: usize = 64;

/// Statistics of segments 0..count of a label image.
pub fn segment_stats(labels: &LabelImage, count: usize, saliency: &[f32]) -> Vec<SegmentStats> {
    let (w, h) = (labels.width as usize, labels.height as usize);
    let blocks: Vec<Vec<SegmentStats>> = (0..h.div_ceil(BLOCK_ROWS))
        .into_par_iter()
        .map(|b| {
            let mut st = vec![SegmentStats::empty(); count];
            for y in b * BLOCK_ROWS..((b + 1) * BLOCK_ROWS).min(h) {
                for x in 0..w {
                    let p = y * w + x;
                    st[labels.labels[p] as usize].add(x as u32, y as u32, saliency[p]);
                }
            }
            st
        })
        .collect();
    let mut total = vec![SegmentStats::empty(); count];
    for b in &blocks {
        for (t, s) in total.iter_mut().zip(b) {
            t.merge(s);
        }
    }
    total
}

/// One segmentation level as the selection sees it.
pub struct LevelInput<'a> {
    pub labels: &'a LabelImage,
    pub stats: &'a [SegmentStats],
    pub threshold: f64,
}

/// Which segments of each level became facets, and the layout they make.
pub struct Selection {
    pub layout: FacetLayout,
    /// `selected[level][segment]`: the segment's facet id, if selected.
    pub facet_of: Vec<Vec<Option<u32>>>,
}

/// Builds the layout: `base` = level-1 segments (level-1 segment j is facet j, so a pixel no
/// quad covers keeps its level-1 segment's facet); every segment with mean saliency >= its
/// level's threshold becomes a quad facet (level-1 ones keep id j, the others get the next
/// ids in level then segment order); polygons in ascending mean saliency, ties in level then
/// segment order, so the most salient is drawn last and occludes the rest.
pub fn select(levels: &[LevelInput]) -> Selection {
    let Some(first) = levels.first() else {
        return Selection { layout: FacetLayout::single(), facet_of: Vec::new() };
    };
    let (w, h) = (first.labels.width, first.labels.height);
    let mut next_id = first.stats.len() as u32;
    let mut facet_of = Vec::new();
    let mut candidates: Vec<(f64, usize, usize, u32)> = Vec::new(); // (saliency, level, segment, id)
    for (li, level) in levels.iter().enumerate() {
        let mut ids = vec![None; level.stats.len()];
        for (si, st) in level.stats.iter().enumerate() {
            let s = st.mean_saliency();
            if st.area == 0 || s < level.threshold {
                continue;
            }
            let id = if li == 0 {
                si as u32
            } else {
                next_id += 1;
                next_id - 1
            };
            ids[si] = Some(id);
            candidates.push((s, li, si, id));
        }
        facet_of.push(ids);
    }
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let polygons = candidates
        .iter()
        .map(|&(_, li, si, id)| FacetPolygon { facet: id, points: levels[li].stats[si].quad(w, h).to_vec() })
        .collect();
    let layout = FacetLayout { facet_count: next_id, base: Some(first.labels.clone()), sites: Vec::new(), polygons };
    Selection { layout, facet_of }
}
