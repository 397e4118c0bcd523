//! Brushwork ("Visible brushwork"): a stroke layer that repaints each plane
//! with short, mostly parallel strokes whose direction changes from plane to plane, as
//! Cezanne's and the cubists' hatching.
//!
//! After Hertzmann ("Painterly rendering with curved brush strokes of multiple sizes", 1998):
//! layers of strokes from coarse to fine, each stroke one colour sampled from the picture under
//! it, the finer layer painted only where the coarser one strays from the picture by more than
//! a threshold (so detail and the legible cues get small strokes, calm areas keep the large
//! ones; an animation's fine strokes fade in across it, so none pops). Unlike his curved
//! strokes, ours are straight dabs aligned per plane: every stroke takes its plane's direction
//! (across the plane's light ramp, `planes`, plus a seeded turn per plane) and paints only the
//! pixels of its own plane and object, so facet borders and silhouettes stay crisp and each
//! plane reads as hatched on its own, in strokes sized by the plane (larger on the large calm
//! planes, finer at the cues), quieter and thinner towards the canvas's edges and corners,
//! where the composition calms. A still's strokes, and an animation frame's strokes fixed on
//! the canvas, lie side by side in parallel rows, in dabs of a shared value (`Hatching`);
//! strokes carried with the surfaces (animation frames) are hatched on the key frame's picture
//! and carried from there with their surface (`strokes::Laid`), or, without one, keep their
//! place and a small turn each.
//!
//! Speed and determinism (Lu, Sander and Finkelstein 2010 splat 60,000 strokes on a GPU): the
//! strokes sit one per cell of a jittered grid (seeded per cell), sorted once by a seeded
//! depth key into per-band lists (bands of rows, compressed rows, no allocation per stroke);
//! then every pixel composites, in that global order, the strokes whose rectangle may reach
//! it. Each pixel is computed alone from the same lists, so the result is identical on any
//! thread count.
//!
//! A stroke's look: a flat colour (the mean of the picture at three points along it, value
//! jittered by a few percent), a flat brush's square ends (its bristles set down a little
//! apart), a crisp anti-aliased edge, bristle streaks along its length (1-D noise across it
//! modulating value) and a dry-brush tail where only the loaded bristles still leave paint.

use std::collections::HashMap;

use glam::{Vec2, Vec4};
use rayon::prelude::*;

use super::inputs::is_subject;
use super::noise::lattice1;
use super::plane_light::Oval;
use super::planes::Plane;
use super::region_means::region_means;
use super::sequence::RegionMeans;
use super::{Canvas, Coverage, Effect, EffectParams, PaintContext, luminance};
use crate::error::Result;
use crate::strokes::{Grid, SeedSource};
use crate::util::rng::{splitmix64, sub_seed, unit_f64};
use layer::{SAMPLES_AT, Stroke, StrokeLayer, Surface, Tint, composite};
use plan::Fragments;
pub use plan::StrokePlan;

const SALT: u64 = 0x6272_7573_6877_6f72; // "brushwor"
/// Grid spacing of stroke anchors, in stroke widths (strokes side by side, overlapping).
pub const SPACING: f32 = 1.8;
/// Largest seeded turn of a plane's strokes off the direction across its ramp, degrees.
pub const PLANE_TURN_DEG: f32 = 20.0;
/// Largest turn of one stroke off its plane's direction, degrees.
pub const STROKE_TURN_DEG: f32 = 6.0;
/// A plane's stroke size grows as its size over the median plane's to this power, within
/// this range (judged blind: docs/look/README.md, round 14).
pub const PLANE_SIZE_POWER: f32 = 0.4;
pub const PLANE_SIZE_RANGE: (f32, f32) = (0.75, 1.4);
/// A carried stroke goes fully onto the row it was laid on while its surface's scale on
/// screen is within the first factor of the key frame's, not at all from the second.
pub const LAID_SCALE: (f32, f32) = (1.5, 2.0);
/// Distance between a plane's hatching rows (a still's strokes), in stroke widths.
pub const HATCH_ROW: f32 = 1.05;
/// Share of a hatched stroke's value change that it shares with the other strokes of its dab
/// (a stroke-long stretch of its row).
pub const DAB_SHARE: f32 = 0.85;
/// Largest relative change of a hatched stroke's value.
pub const HATCH_JITTER: f32 = 0.5;
/// Largest relative change of a stroke's value.
pub const VALUE_JITTER: f32 = 0.35;
/// Value change across the bristle streaks (peak to peak).
pub const BRISTLE_VALUE: f32 = 0.2;
/// Bristle streaks across a stroke (lattice cells of the 1-D noise).
pub const BRISTLES: usize = 3;
/// The fine layer paints where the coarse layer strays from the picture by more than this
/// (mean difference of the square root of luminance, roughly perceptual).
pub const FINE_THRESHOLD: f32 = 0.025;
/// In an animation a fine stroke fades in over this share of the threshold either side of it,
/// so a stroke whose test changes from frame to frame does not pop.
pub const FINE_FADE: f32 = 0.9;
/// A pixel darker than the first share of a stroke's luminance keeps its paint; the stroke
/// covers it fully from the second share on.
pub const DARK_KEPT: (f32, f32) = (0.45, 0.8);
/// How far a stroke's colour goes from the picture under it towards its plane's mean colour:
/// the plane is repainted as a plane, not as the render's smooth shading under glass.
pub const PLANE_FLATTEN: f32 = 0.7;
/// Share of a stroke's value change it loses where the composition is calm (towards the
/// canvas's edges and corners, `plane_light::Oval::calm`, where the planes' ramps calm too):
/// the hatching quietens there (judged blind: docs/look/README.md, round 18).
pub const CORNER_CALM: f32 = 0.6;
/// Share of a stroke's opacity it loses there: thinner paint, the plane under it showing
/// (judged blind: docs/look/README.md, round 19).
pub const CORNER_THIN: f32 = 0.7;
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
        Ok(Box::new(self.brushwork()))
    }
}

impl BrushworkParams {
    /// The stroke layer, sized for this image.
    pub fn brushwork(&self) -> Brushwork {
        Brushwork {
            opacity: self.opacity as f32,
            length: (self.length * self.scale) as f32,
            width: (self.width * self.scale) as f32,
            seed: self.seed,
        }
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

    /// The coarse layer's stroke length and width, pixels: at least `MIN_WIDTH` wide, at least
    /// as long as wide.
    fn coarse_size(&self) -> (f32, f32) {
        let width = self.width.max(MIN_WIDTH);
        (self.length.max(width), width)
    }

    /// The hatching of a plane whose strokes are `length` x `width` pixels.
    fn hatching(&self, (length, width): (f32, f32)) -> Hatching {
        Hatching { row: width * HATCH_ROW, length, seed: sub_seed(self.seed, SALT ^ 1) }
    }

    /// How calm the composition is at a point of the picture (`Oval::calm`: 0 about the
    /// subject, 1 towards the canvas's edges and corners), read where the point's surface lay on
    /// the layout (`PaintContext::plane_point`: a still's pixel, an animation frame's key-frame
    /// point), so a stroke carried with its surface keeps its weight.
    fn calm<'c>(ctx: &'c PaintContext, w: usize, h: usize) -> impl Fn(Vec2) -> f32 + Sync + 'c {
        let oval = ctx.oval(w, h);
        move |p: Vec2| {
            let (x, y) = (p.x.clamp(0.0, (w - 1) as f32) as usize, p.y.clamp(0.0, (h - 1) as f32) as usize);
            Oval::calm(oval.r(ctx.plane_point(y * w + x, w)))
        }
    }

    /// The strokes of layer `layer` (0 coarse, 1 fine), in the seeds' order: one per seed of
    /// `seeds` (`strokes::SeedSource`: a still's jittered grid, or seeds on the surfaces) on a
    /// painted pixel, sized and turned by its plane (each plane's direction and size over
    /// (length, width), by facet id; a missing size is 1); `keep(anchor)`, when given, says at
    /// what share of its opacity a seed gets its stroke (none at 0); `calm(at)` says how calm
    /// the composition is where a stroke is placed (`Brushwork::calm`). All that is random
    /// about a stroke comes from its seed's id.
    #[allow(clippy::too_many_arguments)]
    fn strokes(
        &self,
        layer: u64,
        (length, width): (f32, f32),
        surface: &Surface,
        (angle, scale): (&[Vec2], &[f32]),
        seeds: &dyn SeedSource,
        keep: Option<&(dyn Fn(Vec2) -> f32 + Sync)>,
        calm: &(dyn Fn(Vec2) -> f32 + Sync),
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
                    if !surface.coverage.is_painted(i) {
                        return None;
                    }
                    let region = match seed.plane {
                        // The ground of its plane, under the subject (none known: no stroke).
                        Some(f) if seed.ground => *surface.ground?.get(&f)?,
                        Some(f) => ((f as u64) << 32) | (surface.region(i) & 0xffff_ffff),
                        None => surface.region(i),
                    };
                    let plane = (region >> 32) as usize;
                    let own = 2.0 * r(5) - 1.0;
                    let k = scale.get(plane).copied().unwrap_or(1.0);
                    let (length, width) = (length * k, width * k);
                    let hatch = self.hatching((length, width));
                    // A seed carried with a surface (it reads the picture between pixels:
                    // `Stroke::smooth`) goes onto its plane's row on the picture its hatching is
                    // laid on, carried here by its surface's map, or else keeps its place; one
                    // fixed on the canvas goes onto its plane's row here. Either stays where it
                    // was if its row leaves its plane.
                    let (centre, dir, change) = if let Some(laid) = seed.laid {
                        let (moved, shade) = hatch.place(laid.at, angle[plane], plane as u64, own);
                        let moved = centre + laid_weight(laid.to_frame) * (laid.to_frame * (moved - laid.at));
                        let dir = (laid.to_frame * angle[plane]).try_normalize().unwrap_or(angle[plane]);
                        let inside = surface.painted_in(moved, region).is_some();
                        (if inside { moved } else { centre }, dir, HATCH_JITTER * shade)
                    } else if seed.carried {
                        let turn = (2.0 * r(3) - 1.0) * STROKE_TURN_DEG.to_radians();
                        (centre, Vec2::from_angle(turn).rotate(angle[plane]), VALUE_JITTER * own)
                    } else {
                        let (moved, shade) = hatch.place(centre, angle[plane], plane as u64, own);
                        let inside = surface.painted_in(moved, region).is_some();
                        (if inside { moved } else { centre }, angle[plane], HATCH_JITTER * shade)
                    };
                    // Calmer, thinner strokes where the composition is calm.
                    let quiet = calm(centre);
                    let jitter = 1.0 + change * (1.0 - CORNER_CALM * quiet);
                    // The fine layer's test, where the stroke is (a recorded layer tests every
                    // stroke at its centre afterwards: the same answer).
                    let kept = keep.map_or(1.0, |keep| keep(centre));
                    if kept <= 0.0 {
                        return None;
                    }
                    let half_len = 0.5 * length * (0.8 + 0.4 * r(4));
                    // Its colour is the mean along it, within its region (`Stroke::tint`).
                    let samples = SAMPLES_AT.map(|k| {
                        surface.painted_in(centre + dir * (k * half_len), region).map_or(u32::MAX, |j| j as u32)
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
                        jitter,
                        order: 0,
                        opacity: seed.opacity * (1.0 - CORNER_THIN * quiet) * kept,
                        smooth: seed.carried,
                    })
                }
            })
            .collect()
    }
}

/// Each plane's stroke size over the brushwork's: (its pixels over the median plane's) to the
/// power `PLANE_SIZE_POWER`, within `PLANE_SIZE_RANGE`: longer, wider strokes on the large
/// planes towards the corners, finer ones on the small planes of the subject's cues. Read off
/// the planes a sequence holds (the layout's or key frame's), against the layout frame's median
/// (`Held::plane_median`), so a size does not change as a facet that follows grows or shrinks
/// or a new key frame re-plans the subject.
fn plane_scales(planes: &[Plane], median: Option<f32>) -> Vec<f32> {
    let Some(median) = median.or_else(|| median_size(planes.iter().map(|p| p.pixels))) else {
        return vec![1.0; planes.len()];
    };
    let (lo, hi) = PLANE_SIZE_RANGE;
    planes
        .iter()
        .map(|p| if p.pixels == 0 { 1.0 } else { (p.pixels as f32 / median).powf(PLANE_SIZE_POWER).clamp(lo, hi) })
        .collect()
}

/// The median of the planes' sizes (pixels) that are not 0; None without one.
pub fn median_size(sizes: impl Iterator<Item = u64>) -> Option<f32> {
    let mut sizes: Vec<u64> = sizes.filter(|&n| n > 0).collect();
    let mid = sizes.len() / 2;
    (!sizes.is_empty()).then(|| *sizes.select_nth_unstable(mid).1 as f32)
}

/// How much of its move onto its row a carried stroke makes, by how much its surface has grown
/// or shrunk on screen since its rows were laid (`map`): all of it up to `LAID_SCALE.0` times,
/// none from `LAID_SCALE.1`, where rows laid a stroke width apart would be far apart or
/// crowded here; between, the stroke slides towards its seed as the surface keeps scaling.
fn laid_weight(map: glam::Mat2) -> f32 {
    let s = map.determinant().abs().sqrt();
    let grown = if s > 1.0 { s } else { 1.0 / s.max(1e-6) };
    1.0 - super::planes::smoothstep(LAID_SCALE.0, LAID_SCALE.1, grown)
}

/// A plane's hatching (a still's strokes): its strokes lie side by side in parallel rows
/// `row` pixels apart, exactly along the plane's direction, and each row is cut into dabs a
/// stroke long (staggered from row to row) whose strokes share most of their value change, so
/// the plane reads as short parallel strokes of paint, as Cezanne's constructive strokes.
struct Hatching {
    row: f32,
    length: f32,
    seed: u64,
}

impl Hatching {
    /// Where the stroke anchored at `centre` on plane `plane` (direction `dir`) goes: onto the
    /// plane's nearest row (rows at a seeded phase per plane); and its value change in [-1, 1]
    /// from its dab's and its own (`own`).
    fn place(&self, centre: Vec2, dir: Vec2, plane: u64, own: f32) -> (Vec2, f32) {
        let across = dir.perp();
        let phase = unit_f64(splitmix64(self.seed ^ plane)) as f32;
        let a = centre.dot(across) / self.row - phase;
        let row = a.round();
        let dab = (centre.dot(dir) / self.length + 0.5 * row).floor();
        let h = splitmix64(self.seed ^ splitmix64(plane) ^ splitmix64(row as i64 as u64 ^ (dab as i64 as u64) << 32));
        let shade = 2.0 * unit_f64(h) as f32 - 1.0;
        (centre + across * (self.row * (row - a)), DAB_SHARE * shade + (1.0 - DAB_SHARE) * own)
    }
}

/// The fine layer's test's probes of one stroke (`Brushwork::apply`): each pixel (u32::MAX
/// outside the image) and the picture's value there before the layers.
type Probes = [(u32, f32); 5];

/// The fine layer of one chain: a kept plan's fragments, a layer being recorded (every
/// cell's stroke), or strokes to trace (those of the cells the test keeps).
enum Fine<'p> {
    Kept(&'p Fragments),
    Recorded(StrokeLayer),
    /// The fine strokes' size and the picture before the layers.
    Traced((f32, f32), Vec<Vec4>),
}

impl Effect for Brushwork {
    fn name(&self) -> &'static str {
        "brushwork"
    }

    /// The means of the background's regions and of the open planes' (what a sequence holds:
    /// `sequence::Held::means`).
    fn region_means(&self, canvas: &Canvas<'_>, ctx: &PaintContext) -> Option<RegionMeans> {
        let regions = ctx.regions(canvas.pixel_count());
        let means = region_means(canvas.px, &regions, &Coverage(canvas.coverage.as_deref()));
        Some(means.into_iter().filter(|(r, _)| !is_subject(*r)).collect())
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let (w, h) = (canvas.width as usize, canvas.height as usize);
        if w == 0 || h == 0 || !(self.opacity > 0.0) || !(self.length > 0.0) {
            return Ok(());
        }
        let (length, width) = self.coarse_size();
        let planes = ctx.planes(canvas.width, w * h, self.seed);
        let angle = self.directions(&planes);
        // A sequence sizes them against the layout frame's median plane.
        let scale = plane_scales(&planes, ctx.held().and_then(|h| h.plane_median));
        let seeds: &dyn SeedSource = ctx.seeds().unwrap_or(&Grid);
        let calm = Self::calm(ctx, w, h);
        let opacity = self.opacity.min(1.0);
        // A session keeps the strokes and their fragments (opaque canvases: a transparent
        // one's coverage comes from the colour, which may change under the same regions).
        let kept = ctx.inputs_kept() && !canvas.transparent;
        let (coverage, px) = canvas.coverage_and_pixels();
        let regions = ctx.regions(w * h);
        // A sequence's ground regions by facet (from the layout frame's means), for the
        // strokes of ground seeds. A facet has one (its ground, or its open plane); were there
        // two, the lower would be taken, whatever the map's order.
        let ground: Option<HashMap<u32, u64>> = ctx.held().and_then(|h| h.means.as_ref()).map(|m| {
            let mut ground = HashMap::new();
            for &r in m.keys().filter(|r| !is_subject(**r)) {
                ground.entry((r >> 32) as u32).and_modify(|g: &mut u64| *g = (*g).min(r)).or_insert(r);
            }
            ground
        });
        let surface = Surface { w, h, regions: &regions, coverage, ground: ground.as_ref() };
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
        let coarse_new = old.is_none().then(|| {
            StrokeLayer::new(self.strokes(0, (length, width), &surface, (&angle, &scale), seeds, None, &calm), h)
        });
        let coarse_layer = match (&old, &coarse_new) {
            (Some(plan), _) => &plan.coarse.layer,
            (None, Some(layer)) => layer,
            (None, None) => unreachable!("a layer is made when no plan is kept"),
        };
        let source: &[Vec4] = px;
        let mut means = region_means(source, &regions, &surface.coverage);
        // A sequence's background and open planes take the layout frame's means
        // (`sequence::Held::means`): the subject covering part of one does not change it. One
        // the layout frame did not show keeps none (its strokes take the picture under them):
        // its mean on this frame would change as the subject moves.
        if let Some(held) = ctx.held().and_then(|h| h.means.as_ref()) {
            means.retain(|r, _| is_subject(*r));
            means.extend(held.iter().map(|(r, m)| (*r, *m)));
        }
        let coarse_tints = coarse_layer.tints(source, &means, &surface);
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
        let tints_and_probes =
            |l: &StrokeLayer| (l.tints(source, &means, &surface), l.in_cell_order(|s| before(s.centre)));
        let fine: Option<(Fine, Vec<Tint>, Vec<Probes>)> = match (old.as_deref(), fine_size) {
            (_, None) | (Some(StrokePlan { fine: None, .. }), _) => None,
            (Some(StrokePlan { fine: Some(frags), .. }), _) => {
                let (t, b) = tints_and_probes(&frags.layer);
                Some((Fine::Kept(frags), t, b))
            }
            (None, Some(size)) if record => {
                let l = StrokeLayer::new(self.strokes(1, size, &surface, (&angle, &scale), seeds, None, &calm), h);
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
                composite(&layer, &coarse_tints, px, &surface, opacity);
                None
            }
        };
        let mut recorded_fine = None;
        if let Some((fine, tints, before)) = fine {
            let painted: &[Vec4] = px;
            // How much a fine stroke paints: whether the probes' mean value after the coarse
            // layer strays from before; in an animation, faded in across the threshold.
            let fade =
                ctx.in_sequence().then_some((FINE_THRESHOLD * (1.0 - FINE_FADE), FINE_THRESHOLD * (1.0 + FINE_FADE)));
            let keep = |b: &Probes| -> f32 {
                let (mut e, mut n) = (0.0, 0.0);
                for &(j, v) in b.iter().filter(|(j, _)| *j != u32::MAX) {
                    e += (value(painted[j as usize]) - v).abs();
                    n += 1.0;
                }
                match fade {
                    Some((lo, hi)) => super::planes::smoothstep(lo, hi, e / n),
                    None => f32::from(u8::from(e / n > FINE_THRESHOLD)),
                }
            };
            // The test's answer for every stroke of `l`, in key order.
            let kept_by = |l: &StrokeLayer| l.to_key_order(&before.par_iter().map(&keep).collect::<Vec<f32>>());
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
                    let layer = StrokeLayer::new(
                        self.strokes(1, size, &surface, (&angle, &scale), seeds, Some(&keep_at), &calm),
                        h,
                    );
                    if !layer.strokes.is_empty() {
                        let tints = layer.tints(&source, &means, &surface);
                        composite(&layer, &tints, px, &surface, opacity);
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

mod layer;
mod plan;
#[cfg(test)]
mod tests;
