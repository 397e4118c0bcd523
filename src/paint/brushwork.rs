//! Brushwork (ART.md "Visible brushwork", issue 13): a stroke layer that repaints each plane
//! with short, mostly parallel strokes whose direction changes from plane to plane, as
//! Cezanne's and the cubists' hatching.
//!
//! After Hertzmann ("Painterly rendering with curved brush strokes of multiple sizes", 1998):
//! layers of strokes from coarse to fine, each stroke one colour sampled from the picture
//! under it, the finer layer painted only where the coarser one strays from the picture by
//! more than a threshold (so detail and the legible cues get small strokes, calm areas keep
//! the large ones). Unlike his curved strokes, ours are straight dabs aligned per plane:
//! every stroke takes its plane's direction (across the plane's light ramp, `planes`, plus a
//! seeded turn per plane and a small one per stroke) and paints only the pixels of its own
//! plane and object, so facet borders and silhouettes stay crisp and each plane reads as
//! hatched on its own.
//!
//! Speed and determinism (Lu, Sander and Finkelstein 2010 splat 60,000 strokes on a GPU): the
//! strokes sit one per cell of a jittered grid (seeded per cell), sorted once by a seeded
//! depth key into per-cell lists (compressed rows, no allocation per stroke); then every pixel
//! composites, in that global order, the few strokes listed for its cell. Each pixel is
//! computed alone from the same lists, so the result is identical on any thread count.
//!
//! A stroke's look: a flat colour (the mean of the picture at three points along it, value
//! jittered by a few percent), rounded ends, a crisp anti-aliased edge, bristle streaks along
//! its length (1-D noise across it modulating value) and a dry-brush tail where only the
//! loaded bristles still leave paint.

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::noise::lattice1;
use super::planes::{Plane, smoothstep};
use super::{Canvas, Coverage, Effect, PaintContext, luminance};
use crate::error::Result;
use crate::util::rng::{splitmix64, sub_seed, unit_f64};

const SALT: u64 = 0x6272_7573_6877_6f72; // "brushwor"
/// Grid spacing of stroke anchors, in stroke widths (strokes side by side, overlapping).
pub const SPACING: f32 = 1.5;
/// Largest seeded turn of a plane's strokes off the direction across its ramp, degrees.
pub const PLANE_TURN_DEG: f32 = 20.0;
/// Largest turn of one stroke off its plane's direction, degrees.
pub const STROKE_TURN_DEG: f32 = 6.0;
/// Largest relative change of a stroke's value.
pub const VALUE_JITTER: f32 = 0.16;
/// Value change across the bristle streaks (peak to peak).
pub const BRISTLE_VALUE: f32 = 0.14;
/// Bristle streaks across a stroke (lattice cells of the 1-D noise).
pub const BRISTLES: usize = 4;
/// The fine layer paints where the coarse layer strays from the picture by more than this
/// (mean difference of the square root of luminance, roughly perceptual).
pub const FINE_THRESHOLD: f32 = 0.025;
/// A pixel darker than the first share of a stroke's luminance keeps its paint; the stroke
/// covers it fully from the second share on.
pub const DARK_KEPT: (f32, f32) = (0.45, 0.8);
/// Strokes narrower than this (pixels) are not painted: the layer would be noise.
pub const MIN_WIDTH: f32 = 1.5;

/// A stroke layer over the picture.
pub struct Brushwork {
    /// Opacity of the strokes, in [0, 1].
    pub opacity: f32,
    /// Coarse stroke length, pixels of this image.
    pub length: f32,
    /// Coarse stroke width, pixels of this image.
    pub width: f32,
    pub seed: u64,
}

/// One stroke: a flat dab of `colour`, `2 half_len` long along `dir`, `2 half_wid` wide.
/// The fields every pixel test reads come first (one cache line).
#[derive(Clone, Copy, Debug)]
struct Stroke {
    centre: Vec2,
    dir: Vec2,
    half_len: f32,
    half_wid: f32,
    /// The plane and object it paints (see `Region`).
    region: Region,
    inv_half_len: f32,
    inv_half_wid: f32,
    colour: Vec3,
    /// 1 / luminance of `colour` (0 for black).
    inv_value: f32,
    /// Luminance of `colour`.
    value: f32,
    /// The bristles' loads across the stroke: 1-D value noise lattice values.
    bristles: [f32; BRISTLES + 1],
    /// Depth key: strokes are composited in increasing key order.
    key: u64,
    /// 1 / dir, per axis (`span`).
    inv_dir: Vec2,
}

/// What a stroke may paint: one facet of one object (the background counting as one), as
/// facet id << 32 | object id.
type Region = u64;

/// The strokes of one layer listed per grid cell (compressed rows), each list in key order.
struct Bins {
    cell: f32,
    nx: usize,
    ny: usize,
    start: Vec<u32>,
    items: Vec<u32>,
    strokes: Vec<Stroke>,
}

impl Bins {
    fn new(mut strokes: Vec<Stroke>, cell: f32, width: usize, height: usize) -> Bins {
        strokes.sort_unstable_by_key(|s| s.key);
        let nx = ((width as f32 / cell).ceil() as usize).max(1);
        let ny = ((height as f32 / cell).ceil() as usize).max(1);
        // The cells a stroke's rectangle (widened by the anti-aliasing half pixel) overlaps:
        // those of its bounding box that no axis separates from it (the rectangle's own two
        // axes; the bounding box already settles x and y).
        let cells = |s: &Stroke, mut visit: Box<dyn FnMut(usize) + '_>| {
            let hw = s.half_wid + 1.0;
            let ext = Vec2::new(
                s.dir.x.abs() * s.half_len + s.dir.y.abs() * hw,
                s.dir.y.abs() * s.half_len + s.dir.x.abs() * hw,
            );
            let (lo, hi) = ((s.centre - ext) / cell, (s.centre + ext) / cell);
            let cx = (lo.x.floor().max(0.0) as usize, (hi.x.floor().max(0.0) as usize).min(nx - 1));
            let cy = (lo.y.floor().max(0.0) as usize, (hi.y.floor().max(0.0) as usize).min(ny - 1));
            let half = 0.5 * cell;
            let reach = half * (s.dir.x.abs() + s.dir.y.abs());
            for y in cy.0..=cy.1 {
                for x in cx.0..=cx.1 {
                    let d = Vec2::new((x as f32 + 0.5) * cell, (y as f32 + 0.5) * cell) - s.centre;
                    if d.dot(s.dir).abs() <= s.half_len + reach && d.perp_dot(s.dir).abs() <= hw + reach {
                        visit(y * nx + x);
                    }
                }
            }
        };
        let mut start = vec![0u32; nx * ny + 1];
        for s in &strokes {
            cells(s, Box::new(|c| start[c + 1] += 1));
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; *start.last().unwrap_or(&0) as usize];
        for (k, s) in strokes.iter().enumerate() {
            cells(
                s,
                Box::new(|c| {
                    items[fill[c] as usize] = k as u32;
                    fill[c] += 1;
                }),
            );
        }
        Bins { cell, nx, ny, start, items, strokes }
    }
}

fn fade(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// Paints `s` over colour `c` at pixel centre `p` (of `region`, luminance `value` before the
/// layer), at `opacity`.
#[inline]
fn paint(s: &Stroke, p: Vec2, region: Region, value: f32, c: Vec3, opacity: f32) -> Vec3 {
    let d = p - s.centre;
    let u = d.dot(s.dir);
    if u.abs() >= s.half_len {
        return c;
    }
    let v = d.perp_dot(s.dir).abs();
    if v >= s.half_wid + 0.5 || s.region != region {
        return c;
    }
    let un = u * s.inv_half_len;
    // Rounded ends: the half width narrows as 1 - un^6.
    let un2 = un * un;
    let hw = s.half_wid * (1.0 - un2 * un2 * un2);
    let edge = (hw - v + 0.5).clamp(0.0, 1.0);
    if edge <= 0.0 {
        return c;
    }
    // The bristle under this point: 1-D value noise across the stroke (its two sides alike).
    let x = ((v * s.inv_half_wid) * BRISTLES as f32).min(BRISTLES as f32 - 1e-3);
    let k = x as usize;
    let b = s.bristles[k] + (s.bristles[k + 1] - s.bristles[k]) * fade(x - k as f32);
    let mut alpha = edge * opacity;
    // Dry-brush tail: over the last half of the length only the loaded bristles paint.
    if un > 0.5 {
        let t = (un - 0.5) * 1.4 - 0.2;
        alpha *= smoothstep(t, t + 0.2, b);
    }
    // Dark accents (lines, deep shadows, small dark cues) under a much lighter stroke show
    // through: the painter's drawing stays on top.
    if value < DARK_KEPT.1 * s.value {
        alpha *= smoothstep(DARK_KEPT.0, DARK_KEPT.1, value * s.inv_value);
    }
    let shade = 1.0 + BRISTLE_VALUE * (b - 0.5);
    c.lerp(s.colour * shade, alpha)
}

/// What the layers read: the image size, each pixel's region and whether it is painted.
struct Surface<'a> {
    w: usize,
    h: usize,
    /// `PaintContext::regions`.
    regions: &'a [Region],
    coverage: Coverage<'a>,
}

impl Surface<'_> {
    fn region(&self, i: usize) -> Region {
        self.regions[i]
    }
}

impl Brushwork {
    /// Each plane's stroke direction (unit, image coordinates): across its light ramp (along
    /// the plane's iso-value lines, as hatching follows a plane), turned by a seeded angle of
    /// at most `PLANE_TURN_DEG`.
    pub fn directions(&self, planes: &[Plane]) -> Vec<Vec2> {
        let seed = sub_seed(self.seed, SALT);
        planes
            .iter()
            .enumerate()
            .map(|(f, p)| {
                let turn = (2.0 * unit_f64(splitmix64(seed ^ splitmix64(f as u64))) as f32 - 1.0)
                    * PLANE_TURN_DEG.to_radians();
                Vec2::from_angle(turn).rotate(p.dark.perp())
            })
            .collect()
    }

    /// The strokes of layer `layer` (0 coarse, 1 fine): one per grid cell, anchored at a
    /// seeded point of the cell, on a painted pixel; `keep(anchor)` says whether the cell
    /// gets its stroke. Colours are sampled from `source`.
    #[allow(clippy::too_many_arguments)]
    fn strokes(
        &self,
        layer: u64,
        length: f32,
        width: f32,
        surface: &Surface,
        angle: &[Vec2],
        source: &[Vec4],
        keep: &(dyn Fn(Vec2) -> bool + Sync),
    ) -> Vec<Stroke> {
        let (w, h) = (surface.w, surface.h);
        let cell = width * SPACING;
        let (nx, ny) = ((w as f32 / cell).ceil() as usize, (h as f32 / cell).ceil() as usize);
        let seed = splitmix64(sub_seed(self.seed, SALT) ^ layer);
        (0..ny)
            .into_par_iter()
            .flat_map_iter(|cy| {
                (0..nx).filter_map(move |cx| {
                    let hsh = splitmix64(seed ^ splitmix64((cy * nx + cx) as u64));
                    let r = |k: u64| unit_f64(splitmix64(hsh ^ k)) as f32;
                    let centre = Vec2::new((cx as f32 + r(1)) * cell, (cy as f32 + r(2)) * cell);
                    let (x, y) = (centre.x as usize, centre.y as usize);
                    if x >= w || y >= h {
                        return None;
                    }
                    let i = y * w + x;
                    if !surface.coverage.is_painted(i) || !keep(centre) {
                        return None;
                    }
                    let region = surface.region(i);
                    let turn = (2.0 * r(3) - 1.0) * STROKE_TURN_DEG.to_radians();
                    let dir = Vec2::from_angle(turn).rotate(angle[(region >> 32) as usize]);
                    let half_len = 0.5 * length * (0.8 + 0.4 * r(4));
                    // The mean colour along the stroke, within its region.
                    let (mut sum, mut n) = (Vec3::ZERO, 0.0f32);
                    for k in [-0.6f32, 0.0, 0.6] {
                        let q = centre + dir * (k * half_len);
                        if q.x < 0.0 || q.y < 0.0 || q.x >= w as f32 || q.y >= h as f32 {
                            continue;
                        }
                        let j = q.y as usize * w + q.x as usize;
                        if surface.region(j) == region && surface.coverage.is_painted(j) {
                            sum += source[j].truncate();
                            n += 1.0;
                        }
                    }
                    let colour = sum / n.max(1.0) * (1.0 + VALUE_JITTER * (2.0 * r(5) - 1.0));
                    let bristle_seed = splitmix64(hsh ^ 6);
                    Some(Stroke {
                        centre,
                        dir,
                        half_len,
                        half_wid: 0.5 * width,
                        colour,
                        inv_value: if luminance(colour) > 0.0 { 1.0 / luminance(colour) } else { 0.0 },
                        value: luminance(colour),
                        inv_half_len: 1.0 / half_len,
                        inv_half_wid: 2.0 / width,
                        region,
                        bristles: std::array::from_fn(|k| lattice1(bristle_seed, k as i64)),
                        key: splitmix64(hsh ^ 7),
                        inv_dir: dir.recip(),
                    })
                })
            })
            .collect()
    }
}

/// Composites the strokes of `bins` over every painted pixel of `px` in place: each pixel
/// takes, in key order, the strokes listed for its cell (`Bins::at`), over its colour before
/// the layer. Bands of cell rows in parallel; within a cell stroke by stroke, each over the
/// pixels of the cell its rectangle may reach (a span per row, one pixel wider than the
/// rectangle on each side, the exact test being `paint`'s): every pixel sees the same
/// strokes in the same order as alone, so the result is the same on any thread count.
fn composite(bins: &Bins, px: &mut [Vec4], surface: &Surface, opacity: f32) {
    let (w, h) = (surface.w, surface.h);
    if w == 0 || h == 0 {
        return;
    }
    let cell_of = |p: f32, n: usize| ((p / bins.cell) as usize).min(n - 1);
    // Columns of each cell (cell indices are monotone in x and y).
    let mut columns: Vec<(usize, usize, usize)> = Vec::new();
    for x in 0..w {
        let cx = cell_of(x as f32 + 0.5, bins.nx);
        match columns.last_mut() {
            Some(c) if c.0 == cx => c.2 = x + 1,
            _ => columns.push((cx, x, x + 1)),
        }
    }
    let mut bands: Vec<(usize, usize, usize, &mut [Vec4])> = Vec::new();
    let mut rest = px;
    let mut y0 = 0;
    while y0 < h {
        let cy = cell_of(y0 as f32 + 0.5, bins.ny);
        let mut y1 = y0 + 1;
        while y1 < h && cell_of(y1 as f32 + 0.5, bins.ny) == cy {
            y1 += 1;
        }
        let (band, r) = std::mem::take(&mut rest).split_at_mut((y1 - y0) * w);
        bands.push((cy, y0, y1, band));
        rest = r;
        y0 = y1;
    }
    bands.into_par_iter().for_each(|(cy, y0, y1, band)| {
        // Each pixel's luminance before the layer.
        let value: Vec<f32> = band.iter().map(|p| luminance(p.truncate())).collect();
        for &(cx, x0, x1) in &columns {
            let c = cy * bins.nx + cx;
            for &k in &bins.items[bins.start[c] as usize..bins.start[c + 1] as usize] {
                let s = &bins.strokes[k as usize];
                for y in y0..y1 {
                    let Some((a, b)) = span(s, y as f32 + 0.5, x0, x1) else { continue };
                    let row = (y - y0) * w;
                    for x in a..b {
                        let i = y * w + x;
                        if !surface.coverage.is_painted(i) {
                            continue;
                        }
                        let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                        let p = &mut band[row + x];
                        let painted = paint(s, q, surface.region(i), value[row + x], p.truncate(), opacity);
                        *p = painted.extend(p.w);
                    }
                }
            }
        }
    });
}

/// The columns in [x0, x1) of row centre `py` that stroke `s` may paint: where
/// |u| < half_len and |v| < half_wid + 0.5 (`paint`'s first tests), widened by a pixel on
/// each side against rounding; None when there are none. An axis nearly parallel to the rows
/// does not bound the span (its bound would be large and imprecise).
fn span(s: &Stroke, py: f32, x0: usize, x1: usize) -> Option<(usize, usize)> {
    let dy = py - s.centre.y;
    let (mut lo, mut hi) = (f32::NEG_INFINITY, f32::INFINITY);
    // u = dx dir.x + dy dir.y in (-half_len, half_len).
    if s.dir.x.abs() >= 0.01 {
        let (a, b) = ((-s.half_len - dy * s.dir.y) * s.inv_dir.x, (s.half_len - dy * s.dir.y) * s.inv_dir.x);
        (lo, hi) = (lo.max(a.min(b)), hi.min(a.max(b)));
    } else if (dy * s.dir.y).abs() >= s.half_len + 1.0 {
        return None;
    }
    // v = dx dir.y - dy dir.x in (-(half_wid + 0.5), half_wid + 0.5).
    let hw = s.half_wid + 0.5;
    if s.dir.y.abs() >= 0.01 {
        let (a, b) = ((-hw + dy * s.dir.x) * s.inv_dir.y, (hw + dy * s.dir.x) * s.inv_dir.y);
        (lo, hi) = (lo.max(a.min(b)), hi.min(a.max(b)));
    } else if (dy * s.dir.x).abs() >= hw + 1.0 {
        return None;
    }
    // Pixel x has dx = x + 0.5 - centre.x.
    let a = (lo + s.centre.x - 0.5).floor() - 1.0;
    let b = (hi + s.centre.x - 0.5).ceil() + 2.0;
    let a = if a.is_finite() { a.max(x0 as f32) as usize } else { x0 };
    let b = if b.is_finite() { (b.max(0.0) as usize).min(x1) } else { x1 };
    (a < b).then_some((a, b))
}

impl Effect for Brushwork {
    fn name(&self) -> &'static str {
        "brushwork"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let (w, h) = (canvas.width as usize, canvas.height as usize);
        let width = self.width.max(MIN_WIDTH);
        if w == 0 || h == 0 || !(self.opacity > 0.0) || !(self.length > 0.0) {
            return Ok(());
        }
        let length = self.length.max(width);
        let planes = ctx.planes(canvas.width, w * h, self.seed);
        let angle = self.directions(&planes);
        let source: Vec<Vec4> = canvas.px.to_vec();
        let opacity = self.opacity.min(1.0);
        let (coverage, px) = canvas.coverage_and_pixels();
        let regions = ctx.regions(w * h);
        let surface = Surface { w, h, regions: &regions, coverage };
        let coarse = self.strokes(0, length, width, &surface, &angle, &source, &|_| true);
        let bins = Bins::new(coarse, 0.5 * width * SPACING, w, h);
        composite(&bins, px, &surface, opacity);
        // The fine layer (Hertzmann's next brush): half the size, where the coarse layer
        // strays from the picture.
        let fine_width = 0.5 * width;
        if fine_width >= MIN_WIDTH {
            let value = |c: Vec4| luminance(c.truncate()).max(0.0).sqrt();
            let painted: &[Vec4] = px;
            let r = fine_width.ceil() as isize;
            let error = |p: Vec2| {
                let (x, y) = (p.x as isize, p.y as isize);
                let (mut e, mut n) = (0.0, 0.0);
                for (dx, dy) in [(0, 0), (-r, 0), (r, 0), (0, -r), (0, r)] {
                    let (sx, sy) = (x + dx, y + dy);
                    if sx >= 0 && sy >= 0 && (sx as usize) < w && (sy as usize) < h {
                        let j = sy as usize * w + sx as usize;
                        e += (value(painted[j]) - value(source[j])).abs();
                        n += 1.0;
                    }
                }
                e / n
            };
            let keep = |p: Vec2| error(p) > FINE_THRESHOLD;
            let fine = self.strokes(1, 0.5 * length, fine_width, &surface, &angle, &source, &keep);
            if !fine.is_empty() {
                let bins = Bins::new(fine, 0.5 * fine_width * SPACING, w, h);
                composite(&bins, px, &surface, opacity);
            }
        }
        Ok(())
    }
}
