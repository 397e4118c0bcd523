//! A small layout rasteriser for this module's tests and inspection images (the facets module
//! owns the pipeline's one; both follow `FacetLayout`'s rules: base scaled nearest-neighbour,
//! then nearest site, then polygons in order, a pixel inside when its centre is).

use crate::facets::FacetLayout;

/// Facet id per pixel of a `width` x `height` raster (row 0 at the top). Pixels nothing covers
/// get `u32::MAX`.
pub fn rasterise(layout: &FacetLayout, width: u32, height: u32) -> Vec<u32> {
    let (w, h) = (width as usize, height as usize);
    let mut ids = vec![u32::MAX; w * h];
    if let Some(base) = &layout.base {
        let (bw, bh) = (base.width as usize, base.height as usize);
        if bw > 0 && bh > 0 {
            for y in 0..h {
                let by = ((y * 2 + 1) * bh / (2 * h)).min(bh - 1);
                for x in 0..w {
                    let bx = ((x * 2 + 1) * bw / (2 * w)).min(bw - 1);
                    ids[y * w + x] = base.labels[by * bw + bx];
                }
            }
        }
    }
    if !layout.sites.is_empty() {
        for y in 0..h {
            for x in 0..w {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let mut best = (f64::INFINITY, 0u32);
                for (i, s) in layout.sites.iter().enumerate() {
                    let (dx, dy) = (s[0] * w as f64 - px, s[1] * h as f64 - py);
                    let d = dx * dx + dy * dy;
                    if d < best.0 {
                        best = (d, i as u32);
                    }
                }
                ids[y * w + x] = best.1;
            }
        }
    }
    for poly in &layout.polygons {
        fill_polygon(&poly.points, w, h, |x, y| ids[y * w + x] = poly.facet);
    }
    ids
}

/// Calls `put(x, y)` for every pixel whose centre is inside the polygon (even-odd rule, edges
/// half-open in y and x so shared edges are filled once).
pub fn fill_polygon(points: &[[f64; 2]], w: usize, h: usize, mut put: impl FnMut(usize, usize)) {
    if points.len() < 3 {
        return;
    }
    let pts: Vec<(f64, f64)> = points.iter().map(|p| (p[0] * w as f64, p[1] * h as f64)).collect();
    let ymin = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let ymax = pts.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
    let y0 = ((ymin - 0.5).ceil().max(0.0)) as usize;
    let y1 = ((ymax - 0.5).ceil().clamp(0.0, h as f64)) as usize;
    let mut xs = Vec::new();
    for y in y0..y1 {
        let yc = y as f64 + 0.5;
        xs.clear();
        for i in 0..pts.len() {
            let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
            if (a.1 <= yc && yc < b.1) || (b.1 <= yc && yc < a.1) {
                xs.push(a.0 + (yc - a.1) * (b.0 - a.0) / (b.1 - a.1));
            }
        }
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            let xa = ((pair[0] - 0.5).ceil().max(0.0)) as usize;
            let xb = ((pair[1] - 0.5).ceil().clamp(0.0, w as f64)) as usize;
            for x in xa..xb {
                put(x, y);
            }
        }
    }
}
