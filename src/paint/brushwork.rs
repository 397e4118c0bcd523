//! Brushwork ("Visible brushwork"): a stroke layer that repaints each plane
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
//! depth key into per-band lists (bands of rows, compressed rows, no allocation per stroke);
//! then every pixel composites, in that global order, the strokes whose rectangle may reach
//! it. Each pixel is computed alone from the same lists, so the result is identical on any
//! thread count.
//!
//! A stroke's look: a flat colour (the mean of the picture at three points along it, value
//! jittered by a few percent), rounded ends, a crisp anti-aliased edge, bristle streaks along
//! its length (1-D noise across it modulating value) and a dry-brush tail where only the
//! loaded bristles still leave paint.

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::noise::lattice1;
use super::planes::{Plane, smoothstep};
use super::{Canvas, Coverage, Effect, EffectParams, PaintContext, luminance};
use crate::error::Result;
use crate::strokes::{Grid, SeedSource};
use crate::util::rng::{splitmix64, sub_seed, unit_f64};

const SALT: u64 = 0x6272_7573_6877_6f72; // "brushwor"
/// Grid spacing of stroke anchors, in stroke widths (strokes side by side, overlapping).
pub const SPACING: f32 = 1.8;
/// Largest seeded turn of a plane's strokes off the direction across its ramp, degrees.
pub const PLANE_TURN_DEG: f32 = 20.0;
/// Largest turn of one stroke off its plane's direction, degrees.
pub const STROKE_TURN_DEG: f32 = 6.0;
/// Largest relative change of a stroke's value.
pub const VALUE_JITTER: f32 = 0.16;
/// Value change across the bristle streaks (peak to peak).
pub const BRISTLE_VALUE: f32 = 0.08;
/// Bristle streaks across a stroke (lattice cells of the 1-D noise).
pub const BRISTLES: usize = 3;
/// The fine layer paints where the coarse layer strays from the picture by more than this
/// (mean difference of the square root of luminance, roughly perceptual).
pub const FINE_THRESHOLD: f32 = 0.025;
/// A pixel darker than the first share of a stroke's luminance keeps its paint; the stroke
/// covers it fully from the second share on.
pub const DARK_KEPT: (f32, f32) = (0.45, 0.8);
/// How far a stroke's colour goes from the picture under it towards its plane's mean colour:
/// the plane is repainted as a plane, not as the render's smooth shading under glass.
pub const PLANE_FLATTEN: f32 = 0.45;
/// Strokes narrower than this (pixels) are not painted: the layer would be noise.
pub const MIN_WIDTH: f32 = 1.5;

/// The brushwork's parameters: the strokes' opacity in [0, 1] (0 = off), the coarse strokes'
/// length and width in pixels at 1000 px (this image's pixels: times `scale`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BrushworkParams {
    pub opacity: f64,
    pub length: f64,
    pub width: f64,
    pub scale: f64,
    pub seed: u64,
}

impl EffectParams for BrushworkParams {
    fn is_on(&self) -> bool {
        self.opacity > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Brushwork {
            opacity: self.opacity as f32,
            length: (self.length * self.scale) as f32,
            width: (self.width * self.scale) as f32,
            seed: self.seed,
        }))
    }
}

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

/// One stroke's place and shape: a dab `2 half_len` long along `dir`, `2 half_wid` wide, and
/// where its colour is sampled (its `Tint`, from the picture under it). The fields every pixel
/// test reads come first (one cache line).
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
    /// The bristles' loads across the stroke: 1-D value noise lattice values.
    bristles: [f32; BRISTLES + 1],
    /// Depth key: strokes are composited in increasing key order.
    key: u64,
    /// 1 / dir, per axis (`span`).
    inv_dir: Vec2,
    /// The pixels whose mean colour it takes (three points along it, within its region;
    /// `u32::MAX` for a point outside), and that colour's value jitter factor.
    samples: [u32; 3],
    jitter: f32,
    /// Its place among its layer's strokes in cell (scan) order (`Layer::cells`).
    order: u32,
    /// Its seed's opacity (fading in or out: `strokes::StrokeSeed`).
    opacity: f32,
}

/// A stroke's flat colour: the mean of the picture at its samples, value jittered.
#[derive(Clone, Copy, Debug, Default)]
struct Tint {
    colour: Vec3,
    /// 1 / luminance of `colour` (0 for black).
    inv_value: f32,
    /// Luminance of `colour`.
    value: f32,
}

/// What reads the picture at a stroke (its tint, the fine layer's test's probes around its
/// centre), copied out of the stroke in cell order (`Layer::cells`).
#[derive(Clone, Copy, Debug)]
struct Anchor {
    centre: Vec2,
    samples: [u32; 3],
    jitter: f32,
    /// The region the stroke paints.
    region: Region,
}

impl Anchor {
    /// The stroke's colour: the picture at its samples, drawn `PLANE_FLATTEN` of the way to
    /// its region's mean colour (`means`), value jittered.
    fn tint(&self, source: &[Vec4], means: &RegionMeans) -> Tint {
        let (mut sum, mut n) = (Vec3::ZERO, 0.0f32);
        for &j in self.samples.iter().filter(|&&j| j != u32::MAX) {
            sum += source[j as usize].truncate();
            n += 1.0;
        }
        let local = sum / n.max(1.0);
        let local = means.get(&self.region).map_or(local, |m| local.lerp(*m, PLANE_FLATTEN));
        let colour = local * self.jitter;
        let value = luminance(colour);
        Tint { colour, inv_value: if value > 0.0 { 1.0 / value } else { 0.0 }, value }
    }
}

/// What a stroke may paint: one facet of one object (the background counting as one), as
/// facet id << 32 | object id.
type Region = u64;

/// Rows of a band of the compositing (`Layer`): pixels of different bands are painted in
/// parallel, each band's strokes in key order.
const BAND: usize = 8;

/// The strokes of one layer in key order, listed per band of `BAND` rows (compressed rows):
/// each band lists every stroke whose rectangle (widened by a pixel) reaches one of its rows.
struct Layer {
    start: Vec<u32>,
    items: Vec<u32>,
    strokes: Vec<Stroke>,
    /// What reads the picture at each stroke (its tint, the fine layer's test), in cell
    /// order: walked so, in scan order, not in key order, which jumps across the whole
    /// picture from one stroke to the next (a cache miss each). A copy, not indices into
    /// `strokes`: fetching each stroke in cell order jumps across `strokes` instead (a
    /// cache miss per stroke, most of the per-stroke reads' time on a paint-only change).
    cells: Vec<Anchor>,
    /// Each stroke's (key order) index in `cells`: `to_key_order` reads it in order.
    cell_of: Vec<u32>,
}

impl Layer {
    /// The layer of `strokes`, given in cell order.
    fn new(mut strokes: Vec<Stroke>, height: usize) -> Layer {
        for (k, s) in strokes.iter_mut().enumerate() {
            s.order = k as u32;
        }
        let cells = strokes
            .iter()
            .map(|s| Anchor { centre: s.centre, samples: s.samples, jitter: s.jitter, region: s.region })
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
        Layer { start, items, strokes, cells, cell_of }
    }

    /// `f` of every stroke's anchor, computed and listed in cell order (`cells`).
    fn in_cell_order<T: Send>(&self, f: impl Fn(&Anchor) -> T + Sync) -> Vec<T> {
        self.cells.par_iter().map(&f).collect()
    }

    /// Values listed in cell order (`in_cell_order`), listed in key order.
    fn to_key_order<T: Send + Sync + Copy>(&self, by_cell: &[T]) -> Vec<T> {
        self.cell_of.par_iter().map(|&c| by_cell[c as usize]).collect()
    }

    /// Every stroke's tint from `source`, read in cell order, listed in key order.
    fn tints(&self, source: &[Vec4], means: &RegionMeans) -> Vec<Tint> {
        self.to_key_order(&self.in_cell_order(|s| s.tint(source, means)))
    }
}

fn fade(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// Where stroke `s` paints the pixel centre `d` = (dx, dy) from its centre (of `region`), at
/// `opacity`: the stroke's alpha there before the dark accents, and the bristle's shade; None
/// where it does not paint. `dy_dir` = (dy dir.y, dy dir.x), the same for a whole row. What
/// it paints there is `lay`'s: this part depends on the stroke's shape alone.
#[inline(always)]
fn shape(s: &Stroke, dx: f32, dy_dir: (f32, f32), region: Region, opacity: f32) -> Option<(f32, f32)> {
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
    // Rounded ends: the half width narrows as 1 - un^6.
    let un2 = un * un;
    let hw = s.half_wid * (1.0 - un2 * un2 * un2);
    let edge = (hw - v + 0.5).clamp(0.0, 1.0);
    if edge <= 0.0 {
        return None;
    }
    // The bristle under this point: 1-D value noise across the stroke (its two sides alike).
    let x = ((v * s.inv_half_wid) * BRISTLES as f32).min(BRISTLES as f32 - 1e-3);
    let k = x as usize;
    let b = s.bristles[k] + (s.bristles[k + 1] - s.bristles[k]) * fade(x - k as f32);
    let mut alpha = edge * opacity * s.opacity;
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
fn lay(t: &Tint, value: f32, c: Vec3, mut alpha: f32, shade: f32) -> Vec3 {
    // Dark accents (lines, deep shadows, small dark cues) under a much lighter stroke show
    // through: the painter's drawing stays on top.
    if value < DARK_KEPT.1 * t.value {
        alpha *= smoothstep(DARK_KEPT.0, DARK_KEPT.1, value * t.inv_value);
    }
    c.lerp(t.colour * shade, alpha)
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

    /// The strokes of layer `layer` (0 coarse, 1 fine), in the seeds' order: one per seed of
    /// `seeds` (`strokes::SeedSource`: a still's jittered grid, or seeds on the surfaces) on a
    /// painted pixel; `keep(anchor)`, when given, says whether a seed gets its stroke. All
    /// that is random about a stroke comes from its seed's id.
    fn strokes(
        &self,
        layer: u64,
        (length, width): (f32, f32),
        surface: &Surface,
        angle: &[Vec2],
        seeds: &dyn SeedSource,
        keep: Option<&(dyn Fn(Vec2) -> bool + Sync)>,
    ) -> Vec<Stroke> {
        let (w, h) = (surface.w, surface.h);
        let cell = width * SPACING;
        let seeds = seeds.seeds(sub_seed(self.seed, SALT), layer, cell, w, h);
        seeds
            .par_iter()
            .filter_map(|seed| {
                {
                    let (hsh, centre) = (seed.id, seed.pos);
                    let r = |k: u64| unit_f64(splitmix64(hsh ^ k)) as f32;
                    let (x, y) = (centre.x as usize, centre.y as usize);
                    if !(centre.x >= 0.0 && centre.y >= 0.0) || x >= w || y >= h {
                        return None;
                    }
                    let i = y * w + x;
                    if !surface.coverage.is_painted(i) || keep.is_some_and(|keep| !keep(centre)) {
                        return None;
                    }
                    let region = match seed.plane {
                        Some(f) => ((f as u64) << 32) | (surface.region(i) & 0xffff_ffff),
                        None => surface.region(i),
                    };
                    let turn = (2.0 * r(3) - 1.0) * STROKE_TURN_DEG.to_radians();
                    let dir = Vec2::from_angle(turn).rotate(angle[(region >> 32) as usize]);
                    let half_len = 0.5 * length * (0.8 + 0.4 * r(4));
                    // Its colour is the mean along it, within its region (`Stroke::tint`).
                    let samples = [-0.6f32, 0.0, 0.6].map(|k| {
                        let q = centre + dir * (k * half_len);
                        if q.x < 0.0 || q.y < 0.0 || q.x >= w as f32 || q.y >= h as f32 {
                            return u32::MAX;
                        }
                        let j = q.y as usize * w + q.x as usize;
                        if surface.region(j) == region && surface.coverage.is_painted(j) { j as u32 } else { u32::MAX }
                    });
                    let bristle_seed = splitmix64(hsh ^ 6);
                    Some(Stroke {
                        centre,
                        dir,
                        half_len,
                        half_wid: 0.5 * width,
                        inv_half_len: 1.0 / half_len,
                        inv_half_wid: 2.0 / width,
                        region,
                        bristles: std::array::from_fn(|k| lattice1(bristle_seed, k as i64)),
                        key: splitmix64(hsh ^ 7),
                        inv_dir: dir.recip(),
                        samples,
                        jitter: 1.0 + VALUE_JITTER * (2.0 * r(5) - 1.0),
                        order: 0,
                        opacity: seed.opacity,
                    })
                }
            })
            .collect()
    }
}

/// Visits, band by band (in parallel) and in compositing order, every (pixel, stroke) that
/// the strokes of `layer` may paint: each stroke of a band in key order, over the span of
/// each row its rectangle may reach (one pixel wider than the rectangle on each side, the
/// exact test being `shape`'s). `band` gets the band's pixels and first row, then `visit` each
/// (index within the band, stroke index, dx, dy_dir) of it. Every pixel sees the same strokes
/// in the same order as alone, so the result is the same on any thread count.
fn each_band<T: Send, B: Send>(
    layer: &Layer,
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

/// Composites the strokes of `layer` (tinted `tints`; only the `active` ones when given) over
/// every painted pixel of `px` in place, each pixel over its colour before the layer
/// (`each_band`).
fn composite(layer: &Layer, tints: &[Tint], active: Option<&[bool]>, px: &mut [Vec4], surface: &Surface, opacity: f32) {
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
            if active.is_some_and(|a| !a[k as usize]) {
                return;
            }
            if let Some((alpha, shade)) = shape(&layer.strokes[k as usize], dx, dy_dir, regions[i], opacity) {
                let p = &mut pixels[i];
                *p = lay(&tints[k as usize], value[i], p.truncate(), alpha, shade).extend(p.w);
            }
        },
    );
}

/// One pixel a stroke paints (`shape`'s answer, kept): the pixel (within its band), its alpha
/// before the dark accents and its shade. The stroke is its `Run`'s: 12 bytes, not 16 with
/// the stroke in each (a band lists a stroke's pixels together, `each_band`).
#[derive(Clone, Copy, Debug)]
struct Fragment {
    pixel: u32,
    alpha: f32,
    shade: f32,
}

/// A stroke's fragments in a band: those up to `end` (an index into the band's fragments)
/// from the previous run's end.
#[derive(Clone, Copy, Debug)]
struct Run {
    stroke: u32,
    end: u32,
}

/// One band's fragments in compositing order, grouped in runs of one stroke: a stroke left
/// out (the fine layer's, where its test does not keep it) is skipped without reading its
/// fragments.
#[derive(Default)]
struct Band {
    runs: Vec<Run>,
    fragments: Vec<Fragment>,
}

impl Band {
    fn push(&mut self, stroke: u32, f: Fragment) {
        self.fragments.push(f);
        let end = self.fragments.len() as u32;
        match self.runs.last_mut() {
            Some(r) if r.stroke == stroke => r.end = end,
            _ => self.runs.push(Run { stroke, end }),
        }
    }

    /// Each run's stroke and fragments, in order.
    fn runs(&self) -> impl Iterator<Item = (u32, &[Fragment])> {
        let mut start = 0usize;
        self.runs.iter().map(move |r| {
            let frags = &self.fragments[start..r.end as usize];
            start = r.end as usize;
            (r.stroke, frags)
        })
    }

    fn bytes(&self) -> usize {
        self.fragments.capacity() * size_of::<Fragment>() + self.runs.capacity() * size_of::<Run>()
    }
}

/// A layer's strokes and where they paint, per band in compositing order: what does not
/// depend on the picture's colours, only on the regions, the planes and the strokes' size and
/// opacity. A session keeps it (`StrokePlan`), so a change of colour upstream (a border width,
/// a palette) composites these fragments instead of testing every stroke at every pixel.
struct Fragments {
    layer: Layer,
    bands: Vec<Band>,
}

impl Fragments {
    /// The fragments of `layer`'s strokes, compositing them (tinted `tints`, only the
    /// `active` ones when given) over `px` on the way, as `composite` does.
    fn build(
        layer: Layer,
        surface: &Surface,
        opacity: f32,
        tints: &[Tint],
        active: Option<&[bool]>,
        px: &mut [Vec4],
    ) -> Fragments {
        let w = surface.w;
        // Each band's room for its fragments, from the strokes' mean cover (their area over
        // the image's) with a margin: pushing into it does not move it as it grows (only the
        // pages written are touched).
        let area: f64 = layer.strokes.iter().map(|s| 4.0 * s.half_len as f64 * (s.half_wid as f64 + 0.5)).sum();
        let room = (1.15 * area / (w * surface.h).max(1) as f64 * (BAND * w) as f64) as usize + 64;
        let mut bands: Vec<Band> = (0..surface.h.div_ceil(BAND))
            .map(|_| Band { runs: Vec::new(), fragments: Vec::with_capacity(room) })
            .collect();
        let regions = surface.regions;
        each_band(
            &layer,
            surface,
            bands.iter_mut().zip(px.chunks_mut(BAND * w.max(1))).collect(),
            // The band's regions, and each pixel's luminance before the layer.
            |y0, (_, pixels)| {
                (&regions[y0 * w..], pixels.iter().map(|p| luminance(p.truncate())).collect::<Vec<f32>>())
            },
            |(out, pixels), (regions, value), i, k, dx, dy_dir| {
                if let Some((alpha, shade)) = shape(&layer.strokes[k as usize], dx, dy_dir, regions[i], opacity) {
                    out.push(k, Fragment { pixel: i as u32, alpha, shade });
                    if active.is_none_or(|a| a[k as usize]) {
                        let p = &mut pixels[i];
                        *p = lay(&tints[k as usize], value[i], p.truncate(), alpha, shade).extend(p.w);
                    }
                }
            },
        );
        Fragments { layer, bands }
    }

    fn bytes(&self) -> usize {
        self.bands.iter().map(Band::bytes).sum::<usize>()
            + self.layer.strokes.len() * size_of::<Stroke>()
            + self.layer.cells.len() * size_of::<Anchor>()
            + (self.layer.items.len() + self.layer.start.len() + self.layer.cell_of.len()) * 4
    }

    /// `composite` from the kept fragments: the same pixels.
    fn composite(&self, tints: &[Tint], active: Option<&[bool]>, px: &mut [Vec4], w: usize) {
        px.par_chunks_mut(BAND * w).zip(&self.bands).for_each(|(pixels, band)| {
            let value: Vec<f32> = pixels.iter().map(|p| luminance(p.truncate())).collect();
            for (k, frags) in band.runs() {
                if active.is_some_and(|a| !a[k as usize]) {
                    continue;
                }
                let t = &tints[k as usize];
                for f in frags {
                    let i = f.pixel as usize;
                    let p = &mut pixels[i];
                    *p = lay(t, value[i], p.truncate(), f.alpha, f.shade).extend(p.w);
                }
            }
        });
    }
}

/// What a session keeps of the brushwork between paint-only changes (`PaintInputs`): both
/// layers' fragments, the fine layer's for every cell (which cells paint depends on the
/// colours), for one stroke size, opacity and seed on an opaque canvas.
pub struct StrokePlan {
    key: [u64; 3],
    coarse: Fragments,
    fine: Option<Fragments>,
}

impl StrokePlan {
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.coarse.bytes() + self.fine.as_ref().map_or(0, Fragments::bytes)
    }
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
    // Pixel x has dx = x + 0.5 - centre.x: the span holds every x in
    // (lo + centre.x - 0.5, hi + centre.x - 0.5), widened by the margin.
    let a = (lo + s.centre.x - 0.5 - SPAN_MARGIN).ceil();
    let b = (hi + s.centre.x - 0.5 + SPAN_MARGIN).floor() + 1.0;
    let a = if a.is_finite() { a.max(x0 as f32) as usize } else { x0 };
    let b = if b.is_finite() { (b.max(0.0) as usize).min(x1) } else { x1 };
    (a < b).then_some((a, b))
}

/// The fine layer's test's probes of one stroke (`Brushwork::apply`): each pixel (u32::MAX
/// outside the image) and the picture's value there before the layers.
type Probes = [(u32, f32); 5];

/// The fine layer of one chain: a kept plan's fragments, a layer being recorded (every
/// cell's stroke), or strokes to trace (those of the cells the test keeps).
enum Fine<'p> {
    Kept(&'p Fragments),
    Recorded(Layer),
    /// The fine strokes' size and the picture before the layers.
    Traced((f32, f32), Vec<Vec4>),
}

/// Each region's mean colour (linear RGB) over its painted pixels.
type RegionMeans = std::collections::HashMap<Region, Vec3>;

/// Each region's mean colour over its painted pixels (`regions`: facet << 32 | object),
/// summed in pixel order (the same sums on any thread count).
fn plane_means(source: &[Vec4], regions: &[Region], coverage: &Coverage) -> RegionMeans {
    let mut sums: std::collections::HashMap<Region, ([f64; 3], u64)> = std::collections::HashMap::new();
    for (i, (p, r)) in source.iter().zip(regions).enumerate() {
        if coverage.is_painted(i) {
            let s = sums.entry(*r).or_insert(([0.0; 3], 0));
            s.0[0] += p.x as f64;
            s.0[1] += p.y as f64;
            s.0[2] += p.z as f64;
            s.1 += 1;
        }
    }
    sums.into_iter()
        .map(|(r, (c, n))| {
            let n = n.max(1) as f64;
            (r, Vec3::new((c[0] / n) as f32, (c[1] / n) as f32, (c[2] / n) as f32))
        })
        .collect()
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
        let seeds: &dyn SeedSource = ctx.seeds().unwrap_or(&Grid);
        let opacity = self.opacity.min(1.0);
        // A session keeps the strokes and their fragments (opaque canvases: a transparent
        // one's coverage comes from the colour, which may change under the same regions).
        let kept = ctx.inputs_kept() && !canvas.transparent;
        let (coverage, px) = canvas.coverage_and_pixels();
        let regions = ctx.regions(w * h);
        let surface = Surface { w, h, regions: &regions, coverage };
        let fine_width = 0.5 * width;
        let fine_size = (fine_width >= MIN_WIDTH).then_some((0.5 * length, fine_width));
        let key = [((length.to_bits() as u64) << 32) | width.to_bits() as u64, opacity.to_bits() as u64, self.seed];
        let old = ctx.stroke_plan().filter(|p| kept && p.key == key);
        // Each layer: from the kept fragments; else traced stroke by stroke, and recorded
        // (the fine layer's for every cell, `StrokePlan`) from the second chain on these
        // inputs with these strokes on: recording costs more than tracing, so a facet or
        // camera change, whose inputs serve one chain, does not pay it.
        let record = kept && old.is_none() && ctx.stroke_plan_seen(key);

        // Everything the layers read of the picture before them is read first, in cell order
        // (no copy of the picture): the tints (every stroke's colour comes from the picture
        // under the layers), and the fine layer's test's values of that picture.
        let coarse_new =
            old.is_none().then(|| Layer::new(self.strokes(0, (length, width), &surface, &angle, seeds, None), h));
        let coarse_layer = match (&old, &coarse_new) {
            (Some(plan), _) => &plan.coarse.layer,
            (None, Some(layer)) => layer,
            (None, None) => unreachable!("a layer is made when no plan is kept"),
        };
        let source: &[Vec4] = px;
        let means = plane_means(source, &regions, &surface.coverage);
        let coarse_tints = coarse_layer.tints(source, &means);
        // The fine layer (Hertzmann's next brush): half the size, where the coarse layer
        // strays from the picture. Its candidates: a stroke in every cell (a kept plan's or
        // a recorded one's, all of them; traced, those the test keeps).
        let value = |c: Vec4| luminance(c.truncate()).max(0.0).sqrt();
        let r = fine_size.map_or(0, |size| size.1.ceil() as isize);
        let probes = [(0, 0), (-r, 0), (r, 0), (0, -r), (0, r)];
        // The test's probes around anchor p within the image, and `picture`'s value there.
        let probes_in = |picture: &[Vec4], p: Vec2| -> Probes {
            let (x, y) = (p.x as isize, p.y as isize);
            probes.map(|(dx, dy)| {
                let (sx, sy) = (x + dx, y + dy);
                if sx >= 0 && sy >= 0 && (sx as usize) < w && (sy as usize) < h {
                    let j = sy as usize * w + sx as usize;
                    (j as u32, value(picture[j]))
                } else {
                    (u32::MAX, 0.0)
                }
            })
        };
        // ... in the picture before the layers.
        let before = |p: Vec2| probes_in(source, p);
        // The fine layer with its tints (key order) and probes (cell order).
        let tints_and_probes = |l: &Layer| (l.tints(source, &means), l.in_cell_order(|s| before(s.centre)));
        let fine: Option<(Fine, Vec<Tint>, Vec<Probes>)> = match (old.as_deref(), fine_size) {
            (_, None) | (Some(StrokePlan { fine: None, .. }), _) => None,
            (Some(StrokePlan { fine: Some(frags), .. }), _) => {
                let (t, b) = tints_and_probes(&frags.layer);
                Some((Fine::Kept(frags), t, b))
            }
            (None, Some(size)) if record => {
                let l = Layer::new(self.strokes(1, size, &surface, &angle, seeds, None), h);
                let (t, b) = tints_and_probes(&l);
                Some((Fine::Recorded(l), t, b))
            }
            // Traced: only the cells the test keeps get a stroke (most do not), so the test
            // and the tints read a copy of the picture before the layers.
            (None, Some(size)) => Some((Fine::Traced(size, source.to_vec()), Vec::new(), Vec::new())),
        };

        let coarse = match coarse_new {
            None => {
                if let Some(plan) = &old {
                    plan.coarse.composite(&coarse_tints, None, px, w);
                }
                None
            }
            Some(layer) if record => Some(Fragments::build(layer, &surface, opacity, &coarse_tints, None, px)),
            Some(layer) => {
                composite(&layer, &coarse_tints, None, px, &surface, opacity);
                None
            }
        };
        let mut recorded_fine = None;
        if let Some((fine, tints, before)) = fine {
            let painted: &[Vec4] = px;
            // Whether the probes' mean value after the coarse layer strays from before.
            let keep = |b: &Probes| {
                let (mut e, mut n) = (0.0, 0.0);
                for &(j, v) in b.iter().filter(|(j, _)| *j != u32::MAX) {
                    e += (value(painted[j as usize]) - v).abs();
                    n += 1.0;
                }
                e / n > FINE_THRESHOLD
            };
            // The test's answer for every stroke of `l`, in key order.
            let kept_by = |l: &Layer| l.to_key_order(&before.par_iter().map(&keep).collect::<Vec<bool>>());
            match fine {
                Fine::Kept(frags) => {
                    let a = kept_by(&frags.layer);
                    frags.composite(&tints, Some(&a), px, w);
                }
                Fine::Recorded(l) => {
                    let a = kept_by(&l);
                    recorded_fine = Some(Fragments::build(l, &surface, opacity, &tints, Some(&a), px));
                }
                Fine::Traced(size, source) => {
                    // The test at an anchor, its probes read from the copy of the picture.
                    let keep_at = |p: Vec2| keep(&probes_in(&source, p));
                    let layer = Layer::new(self.strokes(1, size, &surface, &angle, seeds, Some(&keep_at)), h);
                    if !layer.strokes.is_empty() {
                        let tints = layer.tints(&source, &means);
                        composite(&layer, &tints, None, px, &surface, opacity);
                    }
                }
            }
        }
        if let Some(coarse) = coarse {
            ctx.keep_stroke_plan(std::sync::Arc::new(StrokePlan { key, coarse, fine: recorded_fine }));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stroke of the given shape at `centre` along `angle` (radians).
    fn stroke(centre: Vec2, angle: f32, half_len: f32, half_wid: f32) -> Stroke {
        let dir = Vec2::from_angle(angle);
        Stroke {
            centre,
            dir,
            half_len,
            half_wid,
            region: 0,
            inv_half_len: 1.0 / half_len,
            inv_half_wid: 1.0 / half_wid,
            bristles: [1.0; BRISTLES + 1],
            key: 0,
            inv_dir: dir.recip(),
            samples: [u32::MAX; 3],
            jitter: 1.0,
            order: 0,
            opacity: 1.0,
        }
    }

    #[test]
    fn a_band_lists_its_fragments_in_order_in_runs_of_one_stroke() {
        // Fragments pushed stroke after stroke (a stroke coming back after another starts a
        // new run) come back in the order pushed, each with its stroke.
        let pushed: Vec<(u32, u32)> = [(3, 5), (3, 6), (1, 0), (7, 2), (7, 3), (7, 4), (3, 9)].to_vec();
        let mut band = Band::default();
        for &(k, i) in &pushed {
            band.push(k, Fragment { pixel: i, alpha: i as f32, shade: k as f32 });
        }
        assert_eq!(band.runs.len(), 4);
        let back: Vec<(u32, u32)> =
            band.runs().flat_map(|(k, frags)| frags.iter().map(move |f| (k, f.pixel))).collect();
        assert_eq!(back, pushed);
        assert!(band.runs().all(|(k, frags)| frags.iter().all(|f| f.shade == k as f32 && f.alpha == f.pixel as f32)));
        assert_eq!(size_of::<Fragment>(), 12);
    }

    #[test]
    fn span_holds_every_painted_pixel() {
        // Every pixel `shape` paints (tested on whole rows, far beyond the stroke) lies in its
        // row's span, at any angle (axis-parallel ones included), size and place; the span
        // is at most two pixels wider than a row's run of candidates (pixels passing the
        // rectangle tests), and about as many pixels are visited as there are candidates.
        let w = 9000usize;
        let mut visited = 0usize;
        let mut candidates = 0usize;
        for k in 0..4000u64 {
            let r = |j: u64| unit_f64(splitmix64(k * 16 + j)) as f32;
            let angle = match k % 8 {
                0 => 0.0,
                1 => std::f32::consts::FRAC_PI_2,
                2 => std::f32::consts::PI,
                3 => 0.004,
                _ => r(0) * std::f32::consts::TAU,
            };
            let centre = Vec2::new(20.0 + r(1) * (w as f32 - 40.0), 20.0 + r(2) * 8000.0);
            let s = stroke(centre, angle, 0.5 + r(3) * 30.0, 0.5 + r(4) * 8.0);
            let reach = (s.half_len + s.half_wid + 3.0).ceil() as i64;
            let cy = centre.y as i64;
            for y in (cy - reach).max(0)..cy + reach {
                let py = y as f32 + 0.5;
                let dy = py - s.centre.y;
                let dy_dir = (dy * s.dir.y, dy * s.dir.x);
                let sp = span(&s, py, 0, w);
                let (x_lo, x_hi) = ((centre.x as i64 - reach).max(0) as usize, (centre.x as i64 + reach) as usize);
                let mut run = 0;
                for x in x_lo..x_hi.min(w) {
                    let dx = (x as f32 + 0.5) - s.centre.x;
                    let u = dx * s.dir.x + dy_dir.0;
                    let v = (dx * s.dir.y - dy_dir.1).abs();
                    if u.abs() < s.half_len && v < s.half_wid + 0.5 {
                        run += 1;
                    }
                    if shape(&s, dx, dy_dir, 0, 1.0).is_some() {
                        let (a, b) = sp.unwrap_or_else(|| panic!("stroke {k} row {y}: no span, pixel {x} painted"));
                        assert!((a..b).contains(&x), "stroke {k} row {y}: pixel {x} painted outside {a}..{b}");
                    }
                }
                candidates += run;
                visited += sp.map_or(0, |(a, b)| b - a);
                // (An axis within 0.01 of the rows does not bound the span: `span`.)
                if let Some((a, b)) = sp
                    && run > 0
                    && s.dir.x.abs() >= 0.01
                    && s.dir.y.abs() >= 0.01
                {
                    assert!(b - a <= run + 2, "stroke {k} row {y}: span {a}..{b} for {run} candidates");
                }
            }
        }
        assert!(candidates > 100_000);
        assert!((visited as f64) < 1.2 * candidates as f64, "{visited} visits for {candidates} candidates");
    }
}
