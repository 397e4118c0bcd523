//! Smooth plane edges: the regions' edges (facet borders and silhouettes) are drawn per pixel,
//! so a slanted edge is a staircase of pixel steps ("jagged stair-steps" to a painter's eye).
//! Each pixel near an edge takes the share of its own region that a smoothed edge leaves it:
//! the region's indicator (1 in the region, 0 outside) is blurred by a Gaussian, whose half
//! level runs along the edge's true line, not its steps; the signed distance to that line,
//! the blurred value's offset from a half over its gradient, gives the pixel's coverage, and
//! the rest of the pixel takes the colour of its neighbours across the edge. A straight edge
//! along the pixel grid keeps every pixel (its coverage is whole), and thin parts (a sliver,
//! a whisker, under two pixels deep) are left as drawn.

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::Canvas;

/// The Gaussian's standard deviation and its window's radius, pixels.
pub const SIGMA: f32 = 1.5;
pub const RADIUS: i64 = 3;
/// Below this gradient (per pixel) the indicator has no clear edge direction (a corner where
/// several regions meet, a sliver): the pixel is left as drawn.
const MIN_GRADIENT: f32 = 0.08;
/// The region must go on this many pixels further in for its pixel to be smoothed.
const INTERIOR: f32 = 2.0;
/// Farther than this from a region edge pixel, no pixel of another region is in the window.
pub const REACH: f32 = 4.5;

/// The Gaussian's weights over its window, row by row.
pub fn window() -> Vec<f32> {
    let side = (2 * RADIUS + 1) as usize;
    (0..side * side)
        .map(|k| {
            let (dx, dy) = ((k % side) as i64 - RADIUS, (k / side) as i64 - RADIUS);
            (-((dx * dx + dy * dy) as f32) / (2.0 * SIGMA * SIGMA)).exp()
        })
        .collect()
}

/// A region's smoothed edge line near one of its pixels: the unit normal pointing into the
/// region (x right, y down) and the pixel centre's signed distance from the line, pixels
/// (positive inside the region).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeLine {
    pub normal: Vec2,
    pub offset: f32,
}

impl EdgeLine {
    /// The signed distance from the line of the point `(dx, dy)` pixels from the pixel.
    pub fn at(&self, dx: f32, dy: f32) -> f32 {
        self.offset + self.normal.dot(Vec2::new(dx, dy))
    }
}

/// The smoothed edge line of the region `own` (the pixels for which it holds) near pixel `i`
/// of a `w` x `h` grid, from its indicator blurred by `gauss` (`window`): None where no pixel
/// of another region is in the window, where the edge has no clear direction (a corner, a
/// sliver), or where the region does not go on `INTERIOR` pixels in (a thin part).
pub fn edge_line(w: usize, h: usize, i: usize, gauss: &[f32], own: impl Fn(usize) -> bool) -> Option<EdgeLine> {
    let side = (2 * RADIUS + 1) as usize;
    let (x, y) = (i % w, i / w);
    let inside = |dx: i64, dy: i64| -> Option<usize> {
        let (xx, yy) = (x as i64 + dx, y as i64 + dy);
        (xx >= 0 && yy >= 0 && xx < w as i64 && yy < h as i64).then(|| yy as usize * w + xx as usize)
    };
    // The blurred indicator of the pixel's own region and its gradient (the Gaussian's
    // derivative: the weights times the offset over sigma squared).
    let (mut s, mut sx, mut sy, mut total) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    // The window's centroid (non-zero only where the image's border cuts the window).
    let (mut mx, mut my) = (0.0f32, 0.0f32);
    let cut = x < RADIUS as usize || y < RADIUS as usize || x + RADIUS as usize >= w || y + RADIUS as usize >= h;
    let mut edge = false;
    for dy in -RADIUS..=RADIUS {
        for dx in -RADIUS..=RADIUS {
            let Some(j) = inside(dx, dy) else { continue };
            let g = gauss[(dy + RADIUS) as usize * side + (dx + RADIUS) as usize];
            total += g;
            if cut {
                mx += g * dx as f32;
                my += g * dy as f32;
            }
            if own(j) {
                s += g;
                sx += g * dx as f32;
                sy += g * dy as f32;
            } else {
                edge = true;
            }
        }
    }
    if !edge || total <= 0.0 {
        return None;
    }
    // Where the border cuts the window the gradient is taken about its centroid, so the
    // missing side does not read as an edge.
    let s = s / total;
    let gx = (sx - s * mx) / total / (SIGMA * SIGMA);
    let gy = (sy - s * my) / total / (SIGMA * SIGMA);
    let grad = (gx * gx + gy * gy).sqrt();
    if grad < MIN_GRADIENT {
        return None;
    }
    let (nx, ny) = (gx / grad, gy / grad);
    let (ix, iy) = ((x as f32 + INTERIOR * nx).round() as i64, (y as f32 + INTERIOR * ny).round() as i64);
    if inside(ix - x as i64, iy - y as i64).is_none_or(|j| !own(j)) {
        return None;
    }
    Some(EdgeLine { normal: Vec2::new(nx, ny), offset: (s - 0.5) / grad })
}

/// `edge_line`'s offset at a pixel on an edge along the pixel grid (half a pixel, as the
/// Gaussian's window estimates it): what a pixel's distance to a line is measured from, so a
/// line along the grid is at its edge pixels' centres, as the distance to them.
pub fn grid_offset(gauss: &[f32]) -> f32 {
    let (w, h) = (2 * RADIUS as usize + 2, 2 * RADIUS as usize + 1);
    let i = RADIUS as usize * w + RADIUS as usize;
    edge_line(w, h, i, gauss, |j| j % w <= RADIUS as usize).map_or(0.5, |l| l.offset)
}

/// Smooths the edges between `regions` (one key per pixel) on `canvas`. `dist`: each pixel's
/// distance to the nearest region edge pixel (valid below `REACH`).
pub fn smooth_edges(canvas: &mut Canvas<'_>, regions: &[u64], dist: &[f32]) {
    let (w, h) = (canvas.width as usize, canvas.height as usize);
    if w == 0 || h == 0 || regions.len() != w * h || dist.len() != w * h {
        return;
    }
    let gauss = window();
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
        let line = edge_line(w, h, i, &gauss, |j| regions[j] == own)?;
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
    fn the_edge_line_follows_a_slanted_edge_within_a_fifth_of_a_pixel() {
        // Region 1 above the line y = 0.4 x + 3.3 (pixel centres at integer + 0.5).
        let (w, h) = (48usize, 32usize);
        let (a, b) = (0.4f32, 3.3f32);
        let own = |j: usize| ((j / w) as f32 + 0.5) > a * ((j % w) as f32 + 0.5) + b;
        let gauss = window();
        let normal = Vec2::new(-a, 1.0).normalize();
        let mut lines = 0;
        for i in 0..w * h {
            let (x, y) = (i % w, i / w);
            let on_edge = own(i) && y > 0 && !own(i - w);
            if !on_edge || x < 8 || x + 8 > w {
                continue;
            }
            let line = edge_line(w, h, i, &gauss, own).expect("a straight edge has a line");
            let truth = ((y as f32 + 0.5) - a * (x as f32 + 0.5) - b) / (1.0 + a * a).sqrt();
            assert!(line.normal.dot(normal) > 0.995, "pixel {x},{y}: {:?}", line.normal);
            // The estimate's bias is the grid's (a half-pixel offset reads `grid_offset`).
            let bias = grid_offset(&gauss) - 0.5;
            assert!((line.offset - bias - truth).abs() < 0.2, "pixel {x},{y}: {} vs {truth}", line.offset);
            lines += 1;
        }
        assert!(lines > 20);
    }

    #[test]
    fn the_grid_offset_is_about_half_a_pixel() {
        let g = grid_offset(&window());
        assert!((0.45..0.6).contains(&g), "{g}");
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
