//! A region's edge read as a straight line rather than as the steps of its pixels: the
//! region's indicator (1 in the region, 0 outside) blurred by a Gaussian, whose half level runs
//! along the edge's true line; the blurred value's offset from a half over its gradient is a
//! pixel's signed distance to that line. Paint smooths and draws its plane edges by it, and
//! facets that follow the scene read their key frame's edges by it.

use glam::Vec2;

/// The Gaussian's standard deviation and its window's radius, pixels.
pub const SIGMA: f32 = 1.5;
pub const RADIUS: i64 = 3;
/// Below this gradient (per pixel) the indicator has no clear edge direction (a corner where
/// several regions meet, a sliver): no line.
const MIN_GRADIENT: f32 = 0.08;
/// The region must go on this many pixels further in from the pixel for a line (thinner
/// parts, a sliver or a whisker, have none).
const INTERIOR: f32 = 2.0;

/// The Gaussian's window over which edge lines are read: its weights, row by row, and the
/// offset it reads at a pixel on an edge along the pixel grid (half a pixel, as the window
/// estimates it: what a pixel's distance to a line is measured from, so a line along the grid
/// is at its edge pixels' centres, as the distance to them).
pub struct Window {
    weights: Vec<f32>,
    pub grid_offset: f32,
}

impl Window {
    pub fn new() -> Window {
        let side = (2 * RADIUS + 1) as usize;
        let weights = (0..side * side)
            .map(|k| {
                let (dx, dy) = ((k % side) as i64 - RADIUS, (k / side) as i64 - RADIUS);
                (-((dx * dx + dy * dy) as f32) / (2.0 * SIGMA * SIGMA)).exp()
            })
            .collect();
        let mut window = Window { weights, grid_offset: 0.5 };
        let (w, h) = (2 * RADIUS as usize + 2, 2 * RADIUS as usize + 1);
        let i = RADIUS as usize * w + RADIUS as usize;
        if let Some(l) = window.line(w, h, i, |j| j % w <= RADIUS as usize) {
            window.grid_offset = l.offset;
        }
        window
    }

    /// The smoothed edge line of the region `own` (the pixels for which it holds) near pixel
    /// `i` of a `w` x `h` grid, from its indicator blurred over the window: None where no pixel
    /// of another region is in the window, where the edge has no clear direction (a corner, a
    /// sliver), or where the region does not go on `INTERIOR` pixels in (a thin part).
    pub fn line(&self, w: usize, h: usize, i: usize, own: impl Fn(usize) -> bool) -> Option<EdgeLine> {
        edge_line(w, h, i, &self.weights, own)
    }
}

impl Default for Window {
    fn default() -> Window {
        Window::new()
    }
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

/// `Window::line` over the weights `gauss`.
fn edge_line(w: usize, h: usize, i: usize, gauss: &[f32], own: impl Fn(usize) -> bool) -> Option<EdgeLine> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_edge_line_follows_a_slanted_edge_within_a_fifth_of_a_pixel() {
        // Region 1 above the line y = 0.4 x + 3.3 (pixel centres at integer + 0.5).
        let (w, h) = (48usize, 32usize);
        let (a, b) = (0.4f32, 3.3f32);
        let own = |j: usize| ((j / w) as f32 + 0.5) > a * ((j % w) as f32 + 0.5) + b;
        let window = Window::new();
        let normal = Vec2::new(-a, 1.0).normalize();
        let mut lines = 0;
        for i in 0..w * h {
            let (x, y) = (i % w, i / w);
            let on_edge = own(i) && y > 0 && !own(i - w);
            if !on_edge || x < 8 || x + 8 > w {
                continue;
            }
            let line = window.line(w, h, i, own).expect("a straight edge has a line");
            let truth = ((y as f32 + 0.5) - a * (x as f32 + 0.5) - b) / (1.0 + a * a).sqrt();
            assert!(line.normal.dot(normal) > 0.995, "pixel {x},{y}: {:?}", line.normal);
            // The estimate's bias is the grid's (a half-pixel offset reads `grid_offset`).
            let bias = window.grid_offset - 0.5;
            assert!((line.offset - bias - truth).abs() < 0.2, "pixel {x},{y}: {} vs {truth}", line.offset);
            lines += 1;
        }
        assert!(lines > 20);
    }

    #[test]
    fn the_grid_offset_is_about_half_a_pixel() {
        let g = Window::new().grid_offset;
        assert!((0.45..0.6).contains(&g), "{g}");
    }
}
