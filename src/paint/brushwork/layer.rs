//! The strokes of a layer and how they paint: a stroke's shape and colour, the layer's
//! strokes listed per band of rows in compositing order, and the compositing.

use std::collections::HashMap;

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::{BRISTLE_VALUE, BRISTLES, DARK_KEPT, PLANE_FLATTEN};
use crate::paint::planes::smoothstep;
use crate::paint::sequence::RegionMeans;
use crate::paint::{Coverage, luminance};

/// One stroke's place and shape: a dab `2 half_len` long along `dir`, `2 half_wid` wide, and
/// where its colour is sampled (its `Tint`, from the picture under it). The fields every pixel
/// test reads come first (one cache line).
#[derive(Clone, Copy, Debug)]
pub(super) struct Stroke {
    pub(super) centre: Vec2,
    pub(super) dir: Vec2,
    pub(super) half_len: f32,
    pub(super) half_wid: f32,
    /// The plane and object it paints (see `Region`).
    pub(super) region: Region,
    pub(super) inv_half_len: f32,
    pub(super) inv_half_wid: f32,
    /// The bristles' loads across the stroke: 1-D value noise lattice values.
    pub(super) bristles: [f32; BRISTLES + 1],
    /// Depth key: strokes are composited in increasing key order.
    pub(super) key: u64,
    /// 1 / dir, per axis (`span`).
    pub(super) inv_dir: Vec2,
    /// The pixels whose mean colour it takes (three points along it, within its region;
    /// `u32::MAX` for a point outside), and that colour's value jitter factor.
    pub(super) samples: [u32; 3],
    pub(super) jitter: f32,
    /// Its place among its layer's strokes in cell (scan) order (`StrokeLayer::cells`).
    pub(super) order: u32,
    /// Its seed's opacity (fading in or out: `strokes::StrokeSeed`).
    pub(super) opacity: f32,
    /// Its samples read the picture between pixels (animation frames: a stroke carried by a
    /// fraction of a pixel changes its colour by a fraction), not the pixel under each point
    /// (a still's).
    pub(super) smooth: bool,
}

/// A stroke's flat colour: the mean of the picture at its samples, value jittered.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Tint {
    pub(super) colour: Vec3,
    /// 1 / luminance of `colour` (0 for black).
    pub(super) inv_value: f32,
    /// Luminance of `colour`.
    pub(super) value: f32,
}

/// What reads the picture at a stroke (its tint, the fine layer's test's probes around its
/// centre), copied out of the stroke in cell order (`StrokeLayer::cells`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Anchor {
    pub(super) centre: Vec2,
    pub(super) samples: [u32; 3],
    pub(super) jitter: f32,
    /// The region the stroke paints.
    pub(super) region: Region,
    /// Where along the stroke its samples are: `centre + SAMPLES_AT[k] reach`.
    pub(super) reach: Vec2,
    /// Whether the samples read the picture between pixels (`Stroke::smooth`).
    pub(super) smooth: bool,
}

impl Anchor {
    /// The stroke's colour: the picture at its samples, drawn `PLANE_FLATTEN` of the way to
    /// its region's mean colour (`means`), value jittered.
    pub(super) fn tint(&self, source: &[Vec4], means: &RegionMeans, surface: &Surface) -> Tint {
        let (mut sum, mut n) = (Vec3::ZERO, 0.0f32);
        for (&j, k) in self.samples.iter().zip(SAMPLES_AT).filter(|(j, _)| **j != u32::MAX) {
            let between = || bilinear(source, surface, self.region, self.centre + self.reach * k);
            sum += self.smooth.then(between).flatten().unwrap_or_else(|| source[j as usize].truncate());
            n += 1.0;
        }
        let mean = means.get(&self.region);
        // No sample in its region (a ground stroke whose points the subject covers): its
        // region's mean.
        let local = match mean {
            Some(m) if n == 0.0 => *m,
            _ => sum / n.max(1.0),
        };
        let local = mean.map_or(local, |m| local.lerp(*m, PLANE_FLATTEN));
        let colour = local * self.jitter;
        let value = luminance(colour);
        Tint { colour, inv_value: if value > 0.0 { 1.0 / value } else { 0.0 }, value }
    }
}

/// Where along a stroke its colour is sampled, in half lengths from its centre.
pub(super) const SAMPLES_AT: [f32; 3] = [-0.6, 0.0, 0.6];

/// The picture at point `q` (pixels) interpolated between the centres of the (up to) four
/// pixels around it that are painted and of `region`; None where none is.
pub(super) fn bilinear(source: &[Vec4], surface: &Surface, region: Region, q: Vec2) -> Option<Vec3> {
    let (fx, fy) = ((q.x - 0.5).floor(), (q.y - 0.5).floor());
    let (tx, ty) = (q.x - 0.5 - fx, q.y - 0.5 - fy);
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0f32);
    for (dx, dy, wgt) in
        [(0, 0, (1.0 - tx) * (1.0 - ty)), (1, 0, tx * (1.0 - ty)), (0, 1, (1.0 - tx) * ty), (1, 1, tx * ty)]
    {
        let (x, y) = (fx as i64 + dx, fy as i64 + dy);
        if x < 0 || y < 0 || x >= surface.w as i64 || y >= surface.h as i64 || wgt <= 0.0 {
            continue;
        }
        let j = y as usize * surface.w + x as usize;
        if surface.region(j) == region && surface.coverage.is_painted(j) {
            sum += source[j].truncate() * wgt;
            weight += wgt;
        }
    }
    (weight > 1e-6).then(|| sum / weight)
}

/// What a stroke may paint: one facet of one object (the background counting as one), as
/// facet id << 32 | object id.
pub(super) type Region = u64;

/// Rows of a band of the compositing (`StrokeLayer`): pixels of different bands are painted in
/// parallel, each band's strokes in key order.
pub(super) const BAND: usize = 8;

/// The strokes of one layer in key order, listed per band of `BAND` rows (compressed rows):
/// each band lists every stroke whose rectangle (widened by a pixel) reaches one of its rows.
pub(super) struct StrokeLayer {
    pub(super) start: Vec<u32>,
    pub(super) items: Vec<u32>,
    pub(super) strokes: Vec<Stroke>,
    /// What reads the picture at each stroke (its tint, the fine layer's test), in cell
    /// order: walked so, in scan order, not in key order, which jumps across the whole
    /// picture from one stroke to the next (a cache miss each). A copy, not indices into
    /// `strokes`: fetching each stroke in cell order jumps across `strokes` instead (a
    /// cache miss per stroke, most of the per-stroke reads' time on a paint-only change).
    pub(super) cells: Vec<Anchor>,
    /// Each stroke's (key order) index in `cells`: `to_key_order` reads it in order.
    pub(super) cell_of: Vec<u32>,
}

impl StrokeLayer {
    /// The layer of `strokes`, given in cell order.
    pub(super) fn new(mut strokes: Vec<Stroke>, height: usize) -> StrokeLayer {
        for (k, s) in strokes.iter_mut().enumerate() {
            s.order = k as u32;
        }
        let cells = strokes
            .iter()
            .map(|s| Anchor {
                centre: s.centre,
                samples: s.samples,
                jitter: s.jitter,
                region: s.region,
                reach: s.dir * s.half_len,
                smooth: s.smooth,
            })
            .collect();
        strokes.sort_unstable_by_key(|s| s.key);
        let cell_of = strokes.iter().map(|s| s.order).collect();
        let nb = height.div_ceil(BAND).max(1);
        // The bands of the rows a stroke may paint: a painted pixel has |u| < half_len and
        // |v| < half_wid + 0.5, so |dy| < |dir.y| half_len + |dir.x| (half_wid + 0.5);
        // widened by a pixel against rounding.
        let bands = |s: &Stroke| -> Option<(usize, usize)> {
            let ext = s.dir.y.abs() * s.half_len + s.dir.x.abs() * (s.half_wid + 0.5) + 1.0;
            let (lo, hi) = ((s.centre.y - ext - 0.5).floor(), (s.centre.y + ext - 0.5).ceil());
            if !(lo.is_finite() && hi.is_finite()) || hi < 0.0 || lo >= height as f32 {
                return None;
            }
            let (lo, hi) = (lo.max(0.0) as usize, (hi as usize).min(height.max(1) - 1));
            Some((lo / BAND, (hi / BAND).min(nb - 1)))
        };
        let mut start = vec![0u32; nb + 1];
        for s in &strokes {
            if let Some((a, b)) = bands(s) {
                for c in a..=b {
                    start[c + 1] += 1;
                }
            }
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; *start.last().unwrap_or(&0) as usize];
        for (k, s) in strokes.iter().enumerate() {
            if let Some((a, b)) = bands(s) {
                for c in a..=b {
                    items[fill[c] as usize] = k as u32;
                    fill[c] += 1;
                }
            }
        }
        StrokeLayer { start, items, strokes, cells, cell_of }
    }

    /// `f` of every stroke's anchor, computed and listed in cell order (`cells`).
    pub(super) fn in_cell_order<T: Send>(&self, f: impl Fn(&Anchor) -> T + Sync) -> Vec<T> {
        self.cells.par_iter().map(&f).collect()
    }

    /// Values listed in cell order (`in_cell_order`), listed in key order.
    pub(super) fn to_key_order<T: Send + Sync + Copy>(&self, by_cell: &[T]) -> Vec<T> {
        self.cell_of.par_iter().map(|&c| by_cell[c as usize]).collect()
    }

    /// Every stroke's tint from `source`, read in cell order, listed in key order.
    pub(super) fn tints(&self, source: &[Vec4], means: &RegionMeans, surface: &Surface) -> Vec<Tint> {
        self.to_key_order(&self.in_cell_order(|s| s.tint(source, means, surface)))
    }
}

fn fade(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// A stroke's square start, over its half length from its centre: at 0.9 less 0.2 x the
/// bristle's noise, so the bristles set down a little apart, as a flat brush's do (judged
/// blind against rounded ends: docs/look/README.md, round 25).
const FLAT_START: (f32, f32) = (0.9, 0.2);

/// Where stroke `s` paints the pixel centre `d` = (dx, dy) from its centre (of `region`), at
/// `opacity`: the stroke's alpha there before the dark accents, and the bristle's shade; None
/// where it does not paint. `dy_dir` = (dy dir.y, dy dir.x), the same for a whole row. What
/// it paints there is `lay`'s: this part depends on the stroke's shape alone.
#[inline(always)]
pub(super) fn shape(s: &Stroke, dx: f32, dy_dir: (f32, f32), region: Region, opacity: f32) -> Option<(f32, f32)> {
    // u = d . dir and v = |d perp dir|, as `Vec2::dot` and `Vec2::perp_dot` compute them.
    let u = dx * s.dir.x + dy_dir.0;
    if u.abs() >= s.half_len {
        return None;
    }
    let v = (dx * s.dir.y - dy_dir.1).abs();
    if v >= s.half_wid + 0.5 || s.region != region {
        return None;
    }
    let un = u * s.inv_half_len;
    // A flat brush: the stroke keeps its width to its ends, which are cut square.
    let edge = (s.half_wid - v + 0.5).clamp(0.0, 1.0);
    if edge <= 0.0 {
        return None;
    }
    // The bristle under this point: 1-D value noise across the stroke (its two sides alike).
    let x = ((v * s.inv_half_wid) * BRISTLES as f32).min(BRISTLES as f32 - 1e-3);
    let k = x as usize;
    let b = s.bristles[k] + (s.bristles[k + 1] - s.bristles[k]) * fade(x - k as f32);
    let mut alpha = edge * opacity * s.opacity;
    // The square start: each bristle set down a little earlier or later (`FLAT_START`).
    if un < 0.0 {
        let start = FLAT_START.0 - FLAT_START.1 * s.bristles[k];
        alpha *= 1.0 - smoothstep(start - 0.06, start, -un);
    }
    // Dry-brush tail: over the last half of the length only the loaded bristles paint.
    if un > 0.5 {
        let t = (un - 0.5) * 1.4 - 0.2;
        alpha *= smoothstep(t, t + 0.2, b);
    }
    Some((alpha, 1.0 + BRISTLE_VALUE * (b - 0.5)))
}

/// Paints a stroke of tint `t` over colour `c` (luminance `value` before the layer) with the
/// `alpha` and `shade` of `shape`.
#[inline(always)]
pub(super) fn lay(t: &Tint, value: f32, c: Vec3, mut alpha: f32, shade: f32) -> Vec3 {
    // Dark accents (lines, deep shadows, small dark cues) under a much lighter stroke show
    // through: the painter's drawing stays on top.
    if value < DARK_KEPT.1 * t.value {
        alpha *= smoothstep(DARK_KEPT.0, DARK_KEPT.1, value * t.inv_value);
    }
    c.lerp(t.colour * shade, alpha)
}

/// What the layers read: the image size, each pixel's region and whether it is painted.
pub(super) struct Surface<'a> {
    pub(super) w: usize,
    pub(super) h: usize,
    /// `PaintContext::regions`.
    pub(super) regions: &'a [Region],
    pub(super) coverage: Coverage<'a>,
    /// A sequence's still ground: per facet id, the region of its ground pixels (the layout
    /// frame's, `sequence::Held::means`), which the strokes of ground seeds paint
    /// (`strokes::StrokeSeed::ground`).
    pub(super) ground: Option<&'a HashMap<u32, Region>>,
}

impl Surface<'_> {
    pub(super) fn region(&self, i: usize) -> Region {
        self.regions[i]
    }

    /// The pixel under point `q` (pixels) when it lies in the image, is of `region` and is
    /// painted.
    pub(super) fn painted_in(&self, q: Vec2, region: Region) -> Option<usize> {
        if !(q.x >= 0.0 && q.y >= 0.0 && q.x < self.w as f32 && q.y < self.h as f32) {
            return None;
        }
        let j = q.y as usize * self.w + q.x as usize;
        (self.region(j) == region && self.coverage.is_painted(j)).then_some(j)
    }
}

/// Visits, band by band (in parallel) and in compositing order, every (pixel, stroke) that
/// the strokes of `layer` may paint: each stroke of a band in key order, over the span of
/// each row its rectangle may reach (one pixel wider than the rectangle on each side, the
/// exact test being `shape`'s). `band` gets the band's pixels and first row, then `visit` each
/// (index within the band, stroke index, dx, dy_dir) of it. Every pixel sees the same strokes
/// in the same order as alone, so the result is the same on any thread count.
pub(super) fn each_band<T: Send, B: Send>(
    layer: &StrokeLayer,
    surface: &Surface,
    bands: Vec<T>,
    start: impl Fn(usize, &mut T) -> B + Sync,
    visit: impl Fn(&mut T, &mut B, usize, u32, f32, (f32, f32)) + Sync,
) {
    let (w, h) = (surface.w, surface.h);
    bands.into_par_iter().enumerate().for_each(|(band, mut t)| {
        let y0 = band * BAND;
        let y1 = (y0 + BAND).min(h);
        let mut b = start(y0, &mut t);
        for &k in &layer.items[layer.start[band] as usize..layer.start[band + 1] as usize] {
            let s = &layer.strokes[k as usize];
            for y in y0..y1 {
                let py = y as f32 + 0.5;
                let Some((a, e)) = span(s, py, 0, w) else { continue };
                let dy = py - s.centre.y;
                let dy_dir = (dy * s.dir.y, dy * s.dir.x);
                let row = (y - y0) * w;
                for x in a..e {
                    if surface.coverage.is_painted(y0 * w + row + x) {
                        visit(&mut t, &mut b, row + x, k, (x as f32 + 0.5) - s.centre.x, dy_dir);
                    }
                }
            }
        }
    });
}

/// Composites the strokes of `layer` (tinted `tints`) over every painted pixel of `px` in
/// place, each pixel over its colour before the layer (`each_band`).
pub(super) fn composite(layer: &StrokeLayer, tints: &[Tint], px: &mut [Vec4], surface: &Surface, opacity: f32) {
    let w = surface.w;
    if w == 0 || surface.h == 0 {
        return;
    }
    let regions = surface.regions;
    each_band(
        layer,
        surface,
        px.chunks_mut(BAND * w).collect(),
        // The band's regions, and each pixel's luminance before the layer.
        |y0, pixels| (&regions[y0 * w..], pixels.iter().map(|p| luminance(p.truncate())).collect::<Vec<f32>>()),
        |pixels, (regions, value), i, k, dx, dy_dir| {
            if let Some((alpha, shade)) = shape(&layer.strokes[k as usize], dx, dy_dir, regions[i], opacity) {
                let p = &mut pixels[i];
                *p = lay(&tints[k as usize], value[i], p.truncate(), alpha, shade).extend(p.w);
            }
        },
    );
}

/// How far (pixels) `span` reaches beyond the exact bounds of a row, against the rounding of
/// its bounds and of `shape`'s u and v (both read the same `dy`; the rest differs by a few
/// ulps of the coordinates, under 0.01 px below 2^16 px): a pixel `shape` paints is always
/// visited, and about half a pixel per row is visited for nothing (four with the whole-pixel
/// margin before: 30-45% of the visits, `span_holds_every_painted_pixel`).
const SPAN_MARGIN: f32 = 0.25;

/// The columns in [x0, x1) of row centre `py` that stroke `s` may paint: where
/// |u| < half_len and |v| < half_wid + 0.5 (`shape`'s first tests), widened by `SPAN_MARGIN`
/// on each side against rounding; None when there are none. An axis nearly parallel to the
/// rows does not bound the span (its bound would be large and imprecise).
pub(super) fn span(s: &Stroke, py: f32, x0: usize, x1: usize) -> Option<(usize, usize)> {
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
    // Pixel x has dx = x + 0.5 - centre.x: the span holds every x in
    // (lo + centre.x - 0.5, hi + centre.x - 0.5), widened by the margin.
    let a = (lo + s.centre.x - 0.5 - SPAN_MARGIN).ceil();
    let b = (hi + s.centre.x - 0.5 + SPAN_MARGIN).floor() + 1.0;
    let a = if a.is_finite() { a.max(x0 as f32) as usize } else { x0 };
    let b = if b.is_finite() { (b.max(0.0) as usize).min(x1) } else { x1 };
    (a < b).then_some((a, b))
}
