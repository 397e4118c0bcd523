//! Boundary agreement between two segmentations, the quality measure of the tests and of the
//! benchmark's time-against-quality table.

use crate::facets::LabelImage;
use crate::util::grid::Grid;

/// Boundary pixels: those whose right or lower neighbour has another label (so each boundary
/// between two regions is one pixel wide, drawn on its upper/left side).
pub fn boundary_mask(labels: &LabelImage) -> Vec<bool> {
    let grid = Grid::new(labels.width, labels.height);
    (0..labels.labels.len()).map(|p| grid.on_border_forward(&labels.labels, p)).collect()
}

/// Fraction of `from`'s set pixels that lie within Euclidean distance `tolerance` of a set
/// pixel of `to` (1 when `from` has none).
fn matched_fraction(from: &[bool], to: &[bool], w: usize, h: usize, tolerance: u32) -> f64 {
    let t = tolerance as i64;
    let offsets: Vec<(i64, i64)> = (-t..=t)
        .flat_map(|dy| (-t..=t).map(move |dx| (dx, dy)))
        .filter(|(dx, dy)| dx * dx + dy * dy <= t * t)
        .collect();
    let (mut total, mut hit) = (0u64, 0u64);
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            if !from[(y * w as i64 + x) as usize] {
                continue;
            }
            total += 1;
            if offsets.iter().any(|&(dx, dy)| {
                let (u, v) = (x + dx, y + dy);
                u >= 0 && v >= 0 && u < w as i64 && v < h as i64 && to[(v * w as i64 + u) as usize]
            }) {
                hit += 1;
            }
        }
    }
    if total == 0 { 1.0 } else { hit as f64 / total as f64 }
}

/// Boundary agreement of a segmentation with a reference: the boundary F-measure (Martin,
/// Fowlkes and Malik 2004, with a simple distance tolerance instead of their bipartite
/// matching). Precision = fraction of the segmentation's boundary pixels within `tolerance`
/// pixels (Euclidean) of a reference boundary pixel; recall = the same from the reference's
/// side; F = 2 P R / (P + R). 1 when neither has a boundary, 0 when only one has.
/// None when the images differ in size.
pub fn boundary_f_measure(seg: &LabelImage, reference: &LabelImage, tolerance: u32) -> Option<f64> {
    if (seg.width, seg.height) != (reference.width, reference.height) {
        return None;
    }
    let (w, h) = (seg.width as usize, seg.height as usize);
    let a = boundary_mask(seg);
    let b = boundary_mask(reference);
    let (na, nb) = (a.iter().any(|v| *v), b.iter().any(|v| *v));
    if !na && !nb {
        return Some(1.0);
    }
    if !na || !nb {
        return Some(0.0);
    }
    let p = matched_fraction(&a, &b, w, h, tolerance);
    let r = matched_fraction(&b, &a, w, h, tolerance);
    Some(if p + r == 0.0 { 0.0 } else { 2.0 * p * r / (p + r) })
}
