//! Smooth plane edges: the regions' edges (facet borders and silhouettes) are drawn per pixel,
//! so a slanted edge is a staircase of pixel steps ("jagged stair-steps" to a painter's eye).
//! Each pixel near an edge takes the share of its own region that a smoothed edge leaves it:
//! the region's indicator (1 in the region, 0 outside) is blurred by a Gaussian, whose half
//! level runs along the edge's true line, not its steps; the signed distance to that line,
//! the blurred value's offset from a half over its gradient, gives the pixel's coverage, and
//! the rest of the pixel takes the colour of its neighbours across the edge. A straight edge
//! along the pixel grid keeps every pixel (its coverage is whole), and thin parts (a sliver,
//! a whisker, under two pixels deep) are left as drawn.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::Canvas;
use crate::util::edge_line::Window;

/// Farther than this from a region edge pixel, no pixel of another region is in the edge
/// line's window (`util::edge_line::RADIUS`).
pub const REACH: f32 = 4.5;

/// Smooths the edges between `regions` (one key per pixel) on `canvas`. `dist`: each pixel's
/// distance to the nearest region edge pixel (valid below `REACH`).
pub fn smooth_edges(canvas: &mut Canvas<'_>, regions: &[u64], dist: &[f32]) {
    let (w, h) = (canvas.width as usize, canvas.height as usize);
    if w == 0 || h == 0 || regions.len() != w * h || dist.len() != w * h {
        return;
    }
    let window = Window::new();
    // Read first (the new colours of the few pixels that change, in scan order), then write:
    // no copy of the canvas.
    let (coverage, px) = canvas.coverage_and_pixels();
    let before: &[Vec4] = px;
    let smoothed = |i: usize| -> Option<Vec3> {
        let (x, y) = (i % w, i / w);
        if !(dist[i] < REACH) || !coverage.is_painted(i) {
            return None;
        }
        let own = regions[i];
        let line = window.line(w, h, i, |j| regions[j] == own)?;
        let c = (0.5 + line.offset).clamp(0.0, 1.0);
        if c >= 1.0 {
            return None;
        }
        let inside = |dx: i64, dy: i64| -> Option<usize> {
            let (xx, yy) = (x as i64 + dx, y as i64 + dy);
            (xx >= 0 && yy >= 0 && xx < w as i64 && yy < h as i64).then(|| yy as usize * w + xx as usize)
        };
        // Across the edge: the 8-neighbours of other regions, the 4-neighbours counted twice.
        let mut other = Vec3::ZERO;
        let mut n = 0.0;
        for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
            let Some(j) = inside(dx, dy) else { continue };
            if regions[j] != own && coverage.is_painted(j) {
                let k = if dx == 0 || dy == 0 { 2.0 } else { 1.0 };
                other += before[j].truncate() * k;
                n += k;
            }
        }
        (n > 0.0).then(|| before[i].truncate() * c + other / n * (1.0 - c))
    };
    let changes: Vec<(usize, Vec3)> =
        (0..w * h).into_par_iter().with_min_len(w).filter_map(|i| smoothed(i).map(|c| (i, c))).collect();
    for (i, c) in changes {
        px[i] = c.extend(px[i].w);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `regions` painted 0.0 / 1.0 by region (0 dark, else light), smoothed; the grey values.
    fn smoothed(w: usize, h: usize, region: impl Fn(usize, usize) -> u64) -> Vec<f32> {
        let regions: Vec<u64> = (0..w * h).map(|i| region(i % w, i / w)).collect();
        let mut px: Vec<Vec4> =
            regions.iter().map(|&r| Vec3::splat(if r == 0 { 0.0 } else { 1.0 }).extend(1.0)).collect();
        let dist = vec![0.0; w * h];
        let mut canvas = Canvas::new(w as u32, h as u32, &mut px, [0.0; 3], false);
        smooth_edges(&mut canvas, &regions, &dist);
        px.iter().map(|p| p.x).collect()
    }

    #[test]
    fn an_edge_along_the_pixel_grid_stays_crisp() {
        let v = smoothed(24, 16, |x, _| (x >= 12) as u64);
        assert!(v.iter().all(|&g| g == 0.0 || g == 1.0), "{v:?}");
    }

    #[test]
    fn a_slanted_edge_loses_its_steps() {
        // The line y = x / 3: steps three pixels long.
        let (w, h) = (48, 32);
        let v = smoothed(w, h, |x, y| (3 * y > x + 12) as u64);
        let partial = v.iter().filter(|&&g| g > 0.02 && g < 0.98).count();
        assert!(partial > 20, "only {partial} pixels between the two sides");
        // Along a column the grey rises monotonically across the edge, within the two values.
        for x in 8..40 {
            let col: Vec<f32> = (0..h).map(|y| v[y * w + x]).collect();
            assert!(col.iter().all(|g| (0.0..=1.0).contains(g)));
            assert!(col.windows(2).all(|p| p[1] >= p[0] - 1e-6), "column {x}: {col:?}");
        }
    }

    #[test]
    fn thin_parts_are_kept() {
        // A diagonal sliver one pixel wide and a horizontal one two pixels wide.
        let v = smoothed(24, 24, |x, y| (x + y == 23) as u64);
        for y in 0..24 {
            assert_eq!(v[y * 24 + (23 - y)], 1.0, "diagonal sliver pixel {y}");
        }
        let v = smoothed(24, 24, |_, y| (y == 11 || y == 12) as u64);
        assert!(v[11 * 24..13 * 24].iter().all(|&g| g == 1.0), "{:?}", &v[11 * 24..13 * 24]);
    }
}
