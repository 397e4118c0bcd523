//! Painterly effects (SPEC "Painterly effects", thesis 4.4): a fixed chain of post effects on
//! the rendered colour, reading the facet ids and hit buffers, each its own module behind the
//! `Effect` trait and left out of the chain when its setting is off.
//!
//! Order (fixed): chiaroscuro (relights the shading, so it must see the unmodified render) ->
//! silhouettes -> facet borders, symmetric or passage -> gradient overlays (the geometric
//! darkenings and lightenings) -> colour transfer / palette (maps the final luminance onto the
//! painter's colours, so borders and gradients come out in palette colours too) ->
//! quantisation (so the paint has at most K colours) -> per-plane light (the ramp across each
//! plane, after the palette: the palette ranks luminance, and ramps spread over a large
//! backdrop would push a small subject's values to the ends of the ramp) -> brushwork (strokes
//! of the finished colours) -> canvas grain (last: the weave shows through the paint).
//!
//! Background and alpha. An opaque image's background is part of the canvas: every effect
//! paints it (borders cross it, the palette colours it). A transparent image has no background
//! to paint: colour effects touch only what was rendered (coverage > 0), and the darkening
//! effects (borders, silhouettes) become black with alpha, so compositing the PNG over the
//! background colour gives the opaque image wherever only darkening happened. The frame's
//! colour stays in the form `output::encode` expects: colour = foreground premultiplied +
//! (1 - alpha) x background.

pub mod borders;
pub mod chiaroscuro;
pub mod gradients;
pub mod palette;
pub mod quantise;
pub mod silhouettes;
// Issue 13: per-plane light, passage, brushwork, canvas grain, and their measure.
pub mod brushwork;
pub mod canvas;
pub mod measure;
pub mod noise;
pub mod passage;
pub mod plane_light;
pub mod planes;

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::facets::FacetMap;
use crate::film::{Film, PixelHit};
use crate::scene::World;
use crate::shading::LightRig;
pub use palette::Palette;
pub use passage::BorderStyle;

/// The image the effects work on, in place on the frame's colour buffer (row 0 at the top).
/// Each pixel's `xyz` is, on an opaque canvas, the composited colour (linear RGB) and, on a
/// transparent one, the straight (not premultiplied) colour of the painted layer, meaningful
/// where `w > 0`. Its `w` is the coverage on an opaque canvas (never changed) and the painted
/// layer's alpha on a transparent one (darkening effects raise it).
pub struct Canvas<'a> {
    pub width: u32,
    pub height: u32,
    pub px: &'a mut [Vec4],
    /// Transparent canvases: each pixel's rendered coverage (the layer alpha changes).
    /// Opaque canvases keep it in `px[i].w`.
    coverage: Option<Vec<f32>>,
    /// The render's background colour (linear RGB).
    pub background: Vec3,
    /// Whether the output has a transparent background (see the module doc).
    pub transparent: bool,
}

impl<'a> Canvas<'a> {
    /// Paints on `color` (a frame's colour buffer, as `render` writes it): an opaque canvas
    /// uses it as it is; a transparent one un-blends the background first.
    pub fn new(width: u32, height: u32, color: &'a mut [Vec4], background: [f32; 3], transparent: bool) -> Canvas<'a> {
        let bg = Vec3::from(background);
        let coverage = transparent.then(|| {
            let cov = color.par_iter().map(|c| c.w).collect();
            color.par_iter_mut().for_each(|c| {
                let a = c.w;
                let rgb = if a > 0.0 { (c.truncate() - bg * (1.0 - a)) / a } else { Vec3::ZERO };
                *c = rgb.extend(a);
            });
            cov
        });
        Canvas { width, height, px: color, coverage, background: bg, transparent }
    }

    /// Puts the colour back in the form `output::encode` reads: premultiplied + (1 - alpha)
    /// x background on a transparent canvas (an opaque one already is).
    pub fn finish(self) {
        if self.transparent {
            let bg = self.background;
            self.px.par_iter_mut().for_each(|c| *c = (c.truncate() * c.w + bg * (1.0 - c.w)).extend(c.w));
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.px.len()
    }

    /// The rendered coverage of every pixel, and the pixels (split borrows for parallel loops).
    pub fn coverage_and_pixels(&mut self) -> (Coverage<'_>, &mut [Vec4]) {
        (Coverage(self.coverage.as_deref()), &mut *self.px)
    }

    /// Multiplies the colour (not the alpha) of every painted pixel (`Coverage::is_painted`)
    /// by `factor(x, y)`, rows in parallel: the plane light's and the canvas grain's step,
    /// whether their factors are computed on the spot or kept (`PaintContext::factors`).
    pub fn scale_painted(&mut self, factor: impl Fn(usize, usize) -> f32 + Sync) {
        let w = self.width as usize;
        let (coverage, px) = self.coverage_and_pixels();
        px.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
            for (x, p) in row.iter_mut().enumerate() {
                if coverage.is_painted(y * w + x) {
                    *p = (p.truncate() * factor(x, y)).extend(p.w);
                }
            }
        });
    }
}

/// Reads a pixel's rendered coverage (see `Canvas::coverage_and_pixels`).
#[derive(Clone, Copy)]
pub struct Coverage<'a>(Option<&'a [f32]>);

impl Coverage<'_> {
    pub fn of(&self, i: usize, p: &Vec4) -> f32 {
        self.0.map_or(p.w, |c| c[i])
    }

    /// Whether colour effects may repaint pixel `i`: everything on an opaque canvas, what was
    /// rendered (coverage > 0) on a transparent one, so a silhouette's black stays black.
    pub fn is_painted(&self, i: usize) -> bool {
        self.0.is_none_or(|c| c[i] > 0.0)
    }
}

/// Multiplies the whole pixel (foreground and background) by `f` in [0, 1]. On a transparent
/// canvas, as black laid over the pixel with alpha 1 - f.
pub fn darken(p: &mut Vec4, f: f32, transparent: bool) {
    if !transparent {
        *p = (p.truncate() * f).extend(p.w);
        return;
    }
    let a = p.w;
    let a2 = 1.0 - f * (1.0 - a);
    if a2 > 0.0 {
        *p = (p.truncate() * (f * a / a2)).extend(a2);
    }
}

/// Multiplies only the background part (1 - `coverage`) of the pixel by `f` in [0, 1].
/// Opaque: that part is still the plain background colour `bg` (silhouettes run before any
/// effect that repaints the background). Transparent: black with alpha under the unchanged
/// foreground.
pub fn darken_background(p: &mut Vec4, coverage: f32, f: f32, bg: Vec3, transparent: bool) {
    if !transparent {
        let rgb = (p.truncate() - bg * ((1.0 - coverage) * (1.0 - f))).max(Vec3::ZERO);
        *p = rgb.extend(p.w);
        return;
    }
    let a = p.w;
    let a2 = a + (1.0 - a) * (1.0 - f);
    if a2 > 0.0 {
        *p = (p.truncate() * (a / a2)).extend(a2);
    }
}

/// The scene's lights as the render used them (chiaroscuro relights with them).
pub struct Lighting<'a> {
    pub world: &'a World,
    pub rig: &'a LightRig,
    /// The camera's axes: chiaroscuro turns each facet's lights about the view axis.
    pub view: chiaroscuro::ViewAxes,
}

/// What animation frames hold still across a sequence, so that what does not move in the
/// scene does not change in the picture (`Painter::apply_sequence`).
#[derive(Default)]
pub struct Sequence<'a> {
    /// The palette's luminance mapping, decided once (`Painter::palette_key`) instead of from
    /// each frame's own pixels (a moving subject would shift every pixel's rank).
    pub palette: Option<&'a palette::PaletteKey>,
    /// The facet map the planes are read from (the layout's), instead of the frame's own.
    pub planes_from: Option<&'a FacetMap>,
    /// Per facet id, how far its plane moved since `planes_from` (pixels; facets that follow
    /// the scene: `facets::motion::Carried::shift`).
    pub plane_shift: Option<&'a [Vec2]>,
    /// Where strokes go (`strokes::surface`), instead of the still's grid.
    pub seeds: Option<&'a dyn crate::strokes::SeedSource>,
    /// The composition's light centre (the layout frame's subject), instead of the frame's own
    /// subject: a moving subject would relight the still background.
    pub oval: Option<plane_light::Oval>,
}

/// What the effects read besides the canvas.
pub struct PaintContext<'a> {
    /// The representative hit of every pixel (normals for chiaroscuro).
    pub hits: &'a [PixelHit],
    /// Facet id of every pixel; None = one facet (faceting none).
    pub facets: Option<&'a FacetMap>,
    pub lighting: Option<&'a Lighting<'a>>,
    /// What several effects derive from the facet map and the hits alone, computed once.
    inputs: &'a PaintInputs,
    /// `PaintParams::open_planes`.
    open_planes: bool,
    /// Animation frames: what holds still across the sequence.
    sequence: Option<&'a Sequence<'a>>,
}

/// What the effects derive from the facet map and the hits alone (not from the colour, nor
/// from the effects' strengths): each pixel's region, the planes, the distance to the
/// region edges. Computed on first use and shared by the effects of a chain; a session keeps
/// it across paint-only changes (`Painter::apply_with`), since the film and the facet map it
/// was made from did not change. Each entry holds the last value asked for (one seed, one
/// border width), so its memory stays bounded. A one-off render's (`Default`) keeps only
/// the planes (small): each effect's regions and edge distances are freed after it, as
/// before they were shared (tests/memory_bound.rs).
#[derive(Default)]
pub struct PaintInputs {
    keep: bool,
    /// Kept from chain to chain on the same film and facet map (`kept_for_changes`, a
    /// session's): its edges are made again at twice a wider limit asked for
    /// (`PaintContext::edges`), and effects keep per-pixel factors (`PaintContext::factors`).
    across_chains: bool,
    regions: std::sync::Mutex<Option<std::sync::Arc<Vec<u64>>>>,
    planes: std::sync::Mutex<Option<(u64, std::sync::Arc<Vec<planes::Plane>>)>>,
    edges: std::sync::Mutex<Option<(u32, std::sync::Arc<Edges>)>>,
    /// The brushwork's strokes and fragments (kept only).
    strokes: std::sync::Mutex<Option<std::sync::Arc<brushwork::StrokePlan>>>,
    /// The brushwork's key in the last chain (kept only): its strokes are recorded from the
    /// second chain with the same key on.
    strokes_seen: std::sync::Mutex<Option<[u64; 3]>>,
    /// Per-pixel factors an effect derives from its settings alone, the last per effect
    /// (kept only, `PaintContext::factors`).
    factors: std::sync::Mutex<Vec<Factors>>,
}

/// One effect's per-pixel factors and what they were made from: `lasting` ones depend on the
/// effect's settings and the image size alone (not the film nor the facet map), so they
/// outlive the inputs they were kept in (`PaintInputs::kept_for_changes_after`).
#[derive(Clone)]
struct Factors {
    effect: &'static str,
    key: [u64; 4],
    lasting: bool,
    values: std::sync::Arc<Vec<f32>>,
}

/// The nearest region edge of every pixel within a distance (`distance::nearest_features`).
pub struct Edges {
    pub dist: Vec<f32>,
    pub near: Vec<u32>,
    /// Passage's pairs across these edges, made by its first run over them.
    pub passage: std::sync::OnceLock<passage::Pairs>,
}

impl PaintInputs {
    /// Inputs kept from chain to chain (a session's).
    pub fn kept() -> PaintInputs {
        PaintInputs { keep: true, ..PaintInputs::default() }
    }

    /// Kept inputs that also expect the border width to change (a session's lane): edges made
    /// again for a wider border are made at twice its width (`PaintContext::edges`).
    pub fn kept_for_changes() -> PaintInputs {
        PaintInputs { keep: true, across_chains: true, ..PaintInputs::default() }
    }

    /// `kept_for_changes` for another film or facet map, taking over what `old` (the inputs
    /// of the previous one) holds that reads neither: the lasting per-pixel factors (the
    /// canvas weave).
    pub fn kept_for_changes_after(old: Option<&PaintInputs>) -> PaintInputs {
        let lasting = old
            .and_then(|o| o.factors.lock().ok().map(|f| f.iter().filter(|f| f.lasting).cloned().collect()))
            .unwrap_or_default();
        PaintInputs { factors: std::sync::Mutex::new(lasting), ..PaintInputs::kept_for_changes() }
    }

    /// Whether each pixel's region is held (then no effect but chiaroscuro reads the film's
    /// hits: `Painter::reads_hits_from`).
    pub fn has_regions(&self) -> bool {
        self.regions.lock().is_ok_and(|r| r.is_some())
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        let regions = self.regions.lock().map_or(0, |r| r.as_ref().map_or(0, |r| r.len() * 8));
        let planes =
            self.planes.lock().map_or(0, |p| p.as_ref().map_or(0, |(_, p)| p.len() * size_of::<planes::Plane>()));
        let edges = self.edges.lock().map_or(0, |e| {
            e.as_ref()
                .map_or(0, |(_, e)| e.dist.len() * 4 + e.near.len() * 4 + e.passage.get().map_or(0, |p| p.bytes()))
        });
        let strokes = self.strokes.lock().map_or(0, |s| s.as_ref().map_or(0, |s| s.bytes()));
        let factors = self.factors.lock().map_or(0, |f| f.iter().map(|f| f.values.len() * 4).sum());
        (regions + planes + edges + strokes + factors) as u64
    }
}

impl<'a> PaintContext<'a> {
    /// Where the composition's light is centred: the sequence's, else this picture's subject.
    pub fn oval(&self, width: usize, height: usize) -> plane_light::Oval {
        self.sequence.and_then(|s| s.oval).unwrap_or_else(|| plane_light::Oval::of(width, height, self.hits))
    }

    /// Each pixel's region: facet id << 32 | object id (0 without a facet map, 0 without
    /// hits), the background counting as one object; `pixels` of them.
    pub fn regions(&self, pixels: usize) -> std::sync::Arc<Vec<u64>> {
        if let Some(r) = self.inputs.regions.lock().ok().and_then(|g| g.clone()) {
            return r;
        }
        let n = pixels;
        let ids = self.facets.map(|f| &f.ids[..]).filter(|d| d.len() == n);
        let hits = (self.hits.len() == n).then_some(self.hits);
        let open = match (ids, hits) {
            (Some(ids), Some(hits)) if self.open_planes => open_planes(ids, hits, self.facet_count()),
            _ => Vec::new(),
        };
        let r: std::sync::Arc<Vec<u64>> = std::sync::Arc::new(
            (0..n)
                .into_par_iter()
                .map(|i| {
                    let f = ids.map_or(0, |d| d[i]);
                    let object = if open.get(f as usize).copied().unwrap_or(false) {
                        OPEN_REGION
                    } else {
                        hits.map_or(0, |h| h[i].object)
                    };
                    ((f as u64) << 32) | object as u64
                })
                .collect(),
        );
        if self.inputs.keep
            && let Ok(mut g) = self.inputs.regions.lock()
        {
            *g = Some(r.clone());
        }
        r
    }

    /// Whether the inputs are kept beyond this chain (a session's): then the regions are
    /// worth keeping in memory while an effect runs; otherwise an effect may read the facet
    /// map and the hits instead.
    pub fn inputs_kept(&self) -> bool {
        self.inputs.keep
    }

    /// Whether the inputs serve several chains (a session's, `PaintInputs::kept_for_changes`):
    /// then an effect's per-pixel factors are worth keeping (`factors`).
    pub fn kept_across_chains(&self) -> bool {
        self.inputs.across_chains
    }

    /// The facets as planes (`planes::planes`; one plane without a facet map) for `seed`.
    pub fn planes(&self, width: u32, pixels: usize, seed: u64) -> std::sync::Arc<Vec<planes::Plane>> {
        if let Some((s, p)) = self.inputs.planes.lock().ok().and_then(|g| g.clone())
            && s == seed
        {
            return p;
        }
        let from = self.sequence.and_then(|s| s.planes_from).filter(|f| f.ids.len() == pixels).or(self.facets);
        let mut p = match from {
            Some(f) => planes::planes(width, &f.ids, self.facet_count().max(f.facet_count as usize), seed),
            None => planes::planes(width, &vec![0; pixels], 1, seed),
        };
        if let Some(shift) = self.sequence.and_then(|s| s.plane_shift) {
            for (plane, d) in p.iter_mut().zip(shift) {
                plane.centre += *d;
                let along = d.dot(plane.dark);
                plane.span = (plane.span.0 + along, plane.span.1 + along);
            }
        }
        let p = std::sync::Arc::new(p);
        if let Ok(mut g) = self.inputs.planes.lock() {
            *g = Some((seed, p.clone()));
        }
        p
    }

    /// For every pixel within `limit` of a region edge (a pixel whose 4-neighbour is in another
    /// region), the nearest such pixel and its distance. Pixels at `limit` or farther may hold
    /// a nearest edge too: callers read only those closer than `limit`.
    ///
    /// A session's inputs (`kept_for_changes`) are computed at the limit first (a facet or
    /// camera change paints once at that width), then, when a wider limit is asked of the same
    /// inputs, at twice that: they serve every limit up to the one they were made at, so a
    /// border width dragged narrower, or wider within the margin, reuses them: below a limit,
    /// the feature transform gives the same nearest pixel at any larger limit (the features
    /// a larger limit adds are all farther than it, so they never change which parabola is
    /// lowest just left of a pixel, the one `distance::nearest_features` takes on a tie;
    /// `edges_below_a_limit_do_not_depend_on_it` checks it, ties included).
    pub fn edges(&self, width: u32, height: u32, limit: f32) -> std::sync::Arc<Edges> {
        let held = self.inputs.edges.lock().ok().and_then(|g| g.clone());
        if let Some((l, e)) = &held
            && limit <= f32::from_bits(*l)
        {
            return e.clone();
        }
        let limit = if self.inputs.across_chains && held.is_some() { 2.0 * limit } else { limit };
        let (w, h) = (width as usize, height as usize);
        let r = self.regions(w * h);
        let is_edge = |i: usize| {
            let (x, y) = (i % w, i / w);
            (x > 0 && r[i] != r[i - 1])
                || (x + 1 < w && r[i] != r[i + 1])
                || (y > 0 && r[i] != r[i - w])
                || (y + 1 < h && r[i] != r[i + w])
        };
        let (dist, near) = crate::distance::nearest_features(width, height, limit, is_edge);
        drop(r);
        let e = std::sync::Arc::new(Edges { dist, near, passage: std::sync::OnceLock::new() });
        if self.inputs.keep
            && let Ok(mut g) = self.inputs.edges.lock()
        {
            *g = Some((limit.to_bits(), e.clone()));
        }
        e
    }

    /// The per-pixel factors `effect` made for `key`, made by `make` when not held; `lasting`:
    /// they depend on `key` alone, not on the film nor the facet map. For inputs kept across
    /// chains (`kept_across_chains`): an effect of a one-off chain computes its factors as it
    /// applies them, holding no buffer.
    pub fn factors(
        &self,
        effect: &'static str,
        key: [u64; 4],
        lasting: bool,
        make: impl FnOnce() -> Vec<f32>,
    ) -> std::sync::Arc<Vec<f32>> {
        let held = self.inputs.factors.lock().ok().and_then(|f| {
            f.iter().find(|f| f.effect == effect && f.key == key && f.lasting == lasting).map(|f| f.values.clone())
        });
        if let Some(v) = held {
            return v;
        }
        let values = std::sync::Arc::new(make());
        if self.inputs.across_chains
            && let Ok(mut f) = self.inputs.factors.lock()
        {
            f.retain(|f| f.effect != effect);
            f.push(Factors { effect, key, lasting, values: values.clone() });
        }
        values
    }

    /// The brushwork's strokes kept by an earlier chain (`brushwork::StrokePlan`), if any.
    pub(crate) fn stroke_plan(&self) -> Option<std::sync::Arc<brushwork::StrokePlan>> {
        self.inputs.strokes.lock().ok().and_then(|g| g.clone())
    }

    /// Whether the last chain's brushwork had this `key` (kept inputs only); notes it.
    pub(crate) fn stroke_plan_seen(&self, key: [u64; 3]) -> bool {
        self.inputs.keep && self.inputs.strokes_seen.lock().is_ok_and(|mut g| g.replace(key) == Some(key))
    }

    /// Keeps the brushwork's strokes for the next chain (when the inputs are kept).
    pub(crate) fn keep_stroke_plan(&self, plan: std::sync::Arc<brushwork::StrokePlan>) {
        if self.inputs.keep
            && let Ok(mut g) = self.inputs.strokes.lock()
        {
            *g = Some(plan);
        }
    }

    /// Animation frames: the palette's mapping decided for the sequence.
    pub fn palette_key(&self) -> Option<&palette::PaletteKey> {
        self.sequence.and_then(|s| s.palette)
    }

    /// Animation frames: where strokes go.
    pub fn seeds(&self) -> Option<&dyn crate::strokes::SeedSource> {
        self.sequence.and_then(|s| s.seeds)
    }

    /// The facet id of pixel `i` (0 without a facet map).
    pub fn facet(&self, i: usize) -> u32 {
        self.facets.map_or(0, |f| f.ids[i])
    }

    /// Number of facets (1 without a facet map), at least one more than any id.
    pub fn facet_count(&self) -> usize {
        self.facets
            .map_or(1, |f| (f.facet_count as usize).max(f.ids.iter().copied().max().map_or(0, |m| m as usize + 1)))
    }
}

/// The object part of the region of a plane that spans figure and ground (`open_planes`).
const OPEN_REGION: u32 = u32::MAX - 1;
/// A plane spans figure and ground when each has at least this share of its pixels.
pub const OPEN_MIN_SHARE: f64 = 0.15;

/// The planes that span figure and ground (passage: the planes faceting leaves some whole
/// across the outline): each side holds at least `OPEN_MIN_SHARE` of the plane. Their pixels
/// are one region, so strokes, light and joins treat the plane as one and the outline opens
/// inside it.
fn open_planes(ids: &[u32], hits: &[PixelHit], count: usize) -> Vec<bool> {
    let mut on = vec![(0u64, 0u64); count];
    for (&f, h) in ids.iter().zip(hits) {
        if let Some(c) = on.get_mut(f as usize) {
            if h.is_hit() {
                c.0 += 1;
            } else {
                c.1 += 1;
            }
        }
    }
    on.iter()
        .map(|&(a, b)| {
            let t = (a + b) as f64;
            t > 0.0 && a as f64 >= OPEN_MIN_SHARE * t && b as f64 >= OPEN_MIN_SHARE * t
        })
        .collect()
}

/// How far the ochre palette turns a plane at the canvas's edge towards its grey or green
/// (`palette::PlaneHues`).
pub const PLANE_HUE_STRENGTH: f32 = 0.6;

/// One painterly effect. `apply` must be deterministic (no thread-dependent order) and must
/// keep the canvas's alpha conventions (see the module doc).
pub trait Effect: Send + Sync {
    fn name(&self) -> &'static str;
    /// Whether it reads the film's hits (`PaintContext::hits`) besides the regions.
    fn reads_hits(&self) -> bool {
        false
    }
    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()>;
    /// A colour transfer's luminance mapping for this canvas, to hold for a sequence
    /// (`Painter::palette_key`); None for every other effect.
    fn palette_key(&self, _canvas: &Canvas<'_>) -> Option<palette::PaletteKey> {
        None
    }
}

/// What the painterly effects need besides the render. Distances are pixels at 1000 px,
/// converted with `scale` (pixels of this image per such pixel); strengths and fractions in
/// [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub struct PaintParams {
    /// Per-facet variation of light direction and intensity; 0 = off.
    pub chiaroscuro: f64,
    /// Silhouette darkening distance; 0 = off.
    pub silhouette_width: f64,
    pub silhouette_strength: f64,
    /// Facet border darkening distance md of eq 4.8; 0 = off.
    pub border_width: f64,
    pub border_strength: f64,
    /// Fraction of facets with a gradient overlay.
    pub gradients: f64,
    /// A built-in palette mapped onto the luminance ranks.
    pub palette: Palette,
    /// A painting whose colours are mapped instead (overrides `palette`).
    pub palette_image: Option<std::path::PathBuf>,
    /// Quantise to this many colours; 0 = off.
    pub colors: u32,
    /// Issue 13: the light-to-dark ramp across each facet (0 = off), how borders are drawn,
    /// the stroke layer's opacity (0 = off) and stroke size, the canvas weave (0 = off).
    pub plane_light: f64,
    pub border_style: BorderStyle,
    pub brushwork: f64,
    pub stroke_length: f64,
    pub stroke_width: f64,
    pub canvas_grain: f64,
    /// The facets include planes left whole across the subject's outline (the planes
    /// faceting's passage): such a plane is one region for the effects (`PaintContext::regions`).
    pub open_planes: bool,
    pub scale: f64,
    pub seed: u64,
    /// The render's background, linear RGB, and whether the output is transparent.
    pub background: [f32; 3],
    pub transparent: bool,
}

/// One effect of the chain, in chain order (see the module doc for why this order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    Chiaroscuro,
    Silhouettes,
    Borders,
    Gradients,
    Palette,
    Quantise,
    PlaneLight,
    Brushwork,
    CanvasGrain,
}

impl PaintParams {
    /// The effects these parameters turn on, in chain order (decided without reading a file).
    fn chain(&self) -> Vec<Step> {
        let on = [
            (Step::Chiaroscuro, self.chiaroscuro > 0.0),
            (Step::Silhouettes, self.silhouette_width > 0.0 && self.silhouette_strength > 0.0),
            (Step::Borders, self.border_width > 0.0 && self.border_strength > 0.0),
            (Step::Gradients, self.gradients > 0.0),
            (Step::Palette, self.palette_image.is_some() || palette::ramp(self.palette).is_some()),
            (Step::Quantise, self.colors > 0),
            (Step::PlaneLight, self.plane_light > 0.0),
            (Step::Brushwork, self.brushwork > 0.0),
            (Step::CanvasGrain, self.canvas_grain > 0.0),
        ];
        on.into_iter().filter(|(_, on)| *on).map(|(step, _)| step).collect()
    }

    /// Each enabled effect's parameters as text, in chain order (`Painter::keys`): what that
    /// effect reads of these parameters, with the canvas's background and transparency.
    pub fn keys(&self) -> Vec<String> {
        let p = self;
        let canvas = format!("{:?} {}", p.background, p.transparent);
        p.chain()
            .into_iter()
            .map(|step| {
                let own = match step {
                    Step::Chiaroscuro => format!("{} {}", p.chiaroscuro, p.seed),
                    Step::Silhouettes => format!("{} {} {}", p.silhouette_width, p.silhouette_strength, p.scale),
                    Step::Borders => format!(
                        "{} {} {} {:?} {} {} {}",
                        p.border_width,
                        p.border_strength,
                        p.scale,
                        p.border_style,
                        p.seed,
                        p.plane_light,
                        p.open_planes
                    ),
                    Step::Gradients => format!("{} {}", p.gradients, p.seed),
                    Step::Palette => format!("{:?} {:?} {}", p.palette_image, p.palette, p.seed),
                    Step::Quantise => format!("{}", p.colors),
                    Step::PlaneLight => format!("{} {}", p.plane_light, p.seed),
                    Step::Brushwork => {
                        format!("{} {} {} {} {}", p.brushwork, p.stroke_length, p.stroke_width, p.scale, p.seed)
                    }
                    Step::CanvasGrain => format!("{} {} {}", p.canvas_grain, p.scale, p.seed),
                };
                format!("{step:?} {own} {canvas}")
            })
            .collect()
    }

    /// Whether no effect is on: the paint stage is skipped and the render left as traced.
    pub fn is_off(&self) -> bool {
        self.chain().is_empty()
    }
}

/// The enabled effects of a render, in chain order. Built once per settings (it loads the
/// palette painting), reusable for every frame of an animation.
pub struct Painter {
    effects: Vec<Box<dyn Effect>>,
    /// Each effect's parameters, as text (`PaintParams::keys`); empty when not known.
    keys: Vec<String>,
    background: [f32; 3],
    transparent: bool,
    /// `PaintParams::open_planes`.
    open_planes: bool,
}

/// Where a chain may start: the canvas after its first `done` effects, as an earlier run of a
/// chain with the same first `done` effects keys left it (`Painter::apply_from`); `px` None:
/// the film's colour holds that canvas already.
pub struct Resume<'a> {
    pub done: usize,
    pub px: Option<&'a [Vec4]>,
}

impl Painter {
    /// The chain `params` ask for; effects that are off are left out. Reads the palette
    /// painting, if any: built once, it serves every frame of an animation.
    pub fn new(params: &PaintParams) -> Result<Painter> {
        let p = params;
        let mut effects: Vec<Box<dyn Effect>> = Vec::new();
        for step in p.chain() {
            effects.push(match step {
                Step::Chiaroscuro => Box::new(chiaroscuro::Chiaroscuro::new(p.chiaroscuro as f32, p.seed)),
                Step::Silhouettes => Box::new(silhouettes::Silhouettes {
                    width: (p.silhouette_width * p.scale) as f32,
                    strength: p.silhouette_strength as f32,
                }),
                Step::Borders => {
                    let (width, strength) = ((p.border_width * p.scale) as f32, p.border_strength as f32);
                    match p.border_style {
                        BorderStyle::Symmetric => Box::new(borders::Borders { width, strength }),
                        BorderStyle::Passage => Box::new(passage::Passage {
                            width,
                            strength,
                            seed: p.seed,
                            plane_light: p.plane_light as f32,
                        }),
                    }
                }
                Step::Gradients => Box::new(gradients::Gradients { fraction: p.gradients, seed: p.seed }),
                Step::Palette => match (&p.palette_image, palette::ramp(p.palette)) {
                    (Some(path), _) => Box::new(palette::ColourTransfer::from_image(path)?),
                    (None, Some(ramp)) => {
                        let mut t = palette::ColourTransfer::from_ramp(ramp);
                        // The ochre-grey palette of 1910-11 is not one hue: greys and greens too.
                        if p.palette == Palette::OchreGrey {
                            t.hues = Some(palette::PlaneHues { strength: PLANE_HUE_STRENGTH, seed: p.seed });
                        }
                        Box::new(t)
                    }
                    (None, None) => unreachable!("chain() leaves the palette out without one"),
                },
                Step::Quantise => Box::new(quantise::Quantise { colors: p.colors }),
                Step::PlaneLight => Box::new(plane_light::PlaneLight { amount: p.plane_light as f32, seed: p.seed }),
                Step::Brushwork => Box::new(brushwork::Brushwork {
                    opacity: p.brushwork as f32,
                    length: (p.stroke_length * p.scale) as f32,
                    width: (p.stroke_width * p.scale) as f32,
                    seed: p.seed,
                }),
                Step::CanvasGrain => Box::new(canvas::CanvasGrain {
                    amount: p.canvas_grain as f32,
                    period: (canvas::PERIOD as f64 * p.scale) as f32,
                    seed: p.seed,
                }),
            });
        }
        Ok(Painter {
            effects,
            keys: p.keys(),
            background: p.background,
            transparent: p.transparent,
            open_planes: p.open_planes,
        })
    }

    /// Each enabled effect's parameters, as text, in chain order: two painters whose first k
    /// keys agree leave the same canvas after their first k effects (on the same film, facet
    /// map and lights; a palette painting's contents are not in its key).
    pub fn keys(&self) -> &[String] {
        &self.keys
    }

    /// A chain of the given effects (tests, benchmarks).
    pub fn from_effects(effects: Vec<Box<dyn Effect>>, background: [f32; 3], transparent: bool) -> Painter {
        Painter { effects, keys: Vec::new(), background, transparent, open_planes: false }
    }

    pub fn is_empty(&self) -> bool {
        self.effects.is_empty()
    }

    /// Whether an effect from the `start`-th on reads the film's hits besides the regions
    /// (`Effect::reads_hits`).
    pub fn reads_hits_from(&self, start: usize) -> bool {
        self.effects.iter().skip(start).any(|e| e.reads_hits())
    }

    /// Names of the enabled effects, in chain order.
    pub fn names(&self) -> Vec<&'static str> {
        self.effects.iter().map(|e| e.name()).collect()
    }

    /// Runs the chain on `frame`'s colour. With no effect enabled the frame is not touched
    /// (bit-identical). `facets` must match the frame's size.
    pub fn apply(&self, film: &mut Film, facets: Option<&FacetMap>, lighting: Option<&Lighting>) -> Result<()> {
        self.apply_with(film, facets, lighting, &PaintInputs::default())
    }

    /// `apply`, reading and filling `inputs`: those made for this film's hits and this facet
    /// map (a session keeps them across paint-only changes).
    pub fn apply_with(
        &self,
        film: &mut Film,
        facets: Option<&FacetMap>,
        lighting: Option<&Lighting>,
        inputs: &PaintInputs,
    ) -> Result<()> {
        self.apply_from(film, facets, lighting, inputs, None, None).map(|_| ())
    }

    /// `apply_with`, starting from `resume` (its canvas taken as the one after its first
    /// `done` effects) and returning the canvas as it was before effect `keep` (None when
    /// `keep` is None, or not after the start, or past the end).
    pub fn apply_from(
        &self,
        film: &mut Film,
        facets: Option<&FacetMap>,
        lighting: Option<&Lighting>,
        inputs: &PaintInputs,
        resume: Option<Resume<'_>>,
        keep: Option<usize>,
    ) -> Result<Option<Vec<Vec4>>> {
        self.run(film, facets, lighting, inputs, resume, keep, None)
    }

    /// `apply` for a frame of an animation: what `sequence` holds still is read from it.
    pub fn apply_sequence(
        &self,
        film: &mut Film,
        facets: Option<&FacetMap>,
        lighting: Option<&Lighting>,
        sequence: &Sequence,
    ) -> Result<()> {
        self.run(film, facets, lighting, &PaintInputs::default(), None, None, Some(sequence)).map(|_| ())
    }

    /// The palette's luminance mapping of `film` painted by the effects before the palette
    /// (None without a palette): what `Sequence::palette` holds for a sequence.
    pub fn palette_key(
        &self,
        film: &Film,
        facets: Option<&FacetMap>,
        lighting: Option<&Lighting>,
        sequence: &Sequence,
    ) -> Result<Option<palette::PaletteKey>> {
        let mut color = film.color.clone();
        let mut canvas = Canvas::new(film.width, film.height, &mut color, self.background, self.transparent);
        let inputs = PaintInputs::default();
        let ctx = PaintContext {
            hits: &film.hits,
            facets,
            lighting,
            inputs: &inputs,
            open_planes: self.open_planes,
            sequence: Some(sequence),
        };
        for e in &self.effects {
            if let Some(key) = e.palette_key(&canvas) {
                return Ok(Some(key));
            }
            e.apply(&mut canvas, &ctx)?;
        }
        Ok(None)
    }

    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        film: &mut Film,
        facets: Option<&FacetMap>,
        lighting: Option<&Lighting>,
        inputs: &PaintInputs,
        resume: Option<Resume<'_>>,
        keep: Option<usize>,
        sequence: Option<&Sequence>,
    ) -> Result<Option<Vec<Vec4>>> {
        if self.effects.is_empty() {
            return Ok(None);
        }
        if let Some(f) =
            facets.filter(|f| f.width != film.width || f.height != film.height || f.ids.len() != film.pixel_count())
        {
            return Err(Error::Internal(format!(
                "painterly effects: the facet map is {}x{} but the image is {}x{}",
                f.width, f.height, film.width, film.height
            )));
        }
        let (w, h) = (film.width, film.height);
        let mut canvas = Canvas::new(w, h, &mut film.color, self.background, self.transparent);
        let ctx = PaintContext { hits: &film.hits, facets, lighting, inputs, open_planes: self.open_planes, sequence };
        let mut start = 0;
        if let Some(r) =
            resume.filter(|r| r.done <= self.effects.len() && r.px.is_none_or(|px| px.len() == canvas.px.len()))
        {
            if let Some(px) = r.px {
                canvas.px.par_iter_mut().zip(px).for_each(|(p, q)| *p = *q);
            }
            start = r.done;
        }
        let mut kept = None;
        let mut result = Ok(());
        for (k, e) in self.effects.iter().enumerate().skip(start) {
            if keep == Some(k) && k > start {
                kept = Some(canvas.px.to_vec());
            }
            result = e.apply(&mut canvas, &ctx);
            if result.is_err() {
                break;
            }
        }
        canvas.finish();
        result.map(|()| kept)
    }
}

/// Builds the chain from `params` and runs it on `film` (see `Painter`).
pub fn apply_chain(
    film: &mut Film,
    facets: Option<&FacetMap>,
    params: &PaintParams,
    lighting: Option<&Lighting>,
) -> Result<()> {
    Painter::new(params)?.apply(film, facets, lighting)
}

/// Luminance of linear RGB (Rec. 709), as `shading::luminance`.
pub fn luminance(c: Vec3) -> f32 {
    crate::shading::luminance(c)
}

/// Number of luminance levels the rank-based effects sort into: far finer than the 8-bit
/// output, and a counting sort over them is linear time.
pub const KEY_LEVELS: usize = 1 << 16;

/// The painted pixels' luminances as sortable keys: `keys[i]` = sqrt(L / L_max) in 16 bits
/// (square root: more levels in the shadows, roughly perceptual), `UNPAINTED` for pixels the
/// effects do not paint, plus the histogram of keys. Monotone: L_a < L_b implies
/// key_a <= key_b, so mapping by key preserves luminance order; equal keys are ties and get
/// the same treatment (deterministic, and flat areas stay flat).
pub struct LuminanceKeys {
    pub keys: Vec<u32>,
    pub histogram: Vec<u32>,
    /// Number of painted pixels.
    pub total: u64,
}

/// The key of a pixel colour effects leave alone.
pub const UNPAINTED: u32 = u32::MAX;

impl LuminanceKeys {
    pub fn new(canvas: &Canvas) -> LuminanceKeys {
        let coverage = Coverage(canvas.coverage.as_deref());
        let lum = |(i, p): (usize, &Vec4)| if coverage.is_painted(i) { luminance(p.truncate()).max(0.0) } else { -1.0 };
        let max = canvas.px.par_iter().enumerate().map(lum).reduce(|| 0.0f32, f32::max);
        let scale = if max > 0.0 && max.is_finite() { 1.0 / max } else { 0.0 };
        let top = (KEY_LEVELS - 1) as f32;
        let keys: Vec<u32> = canvas
            .px
            .par_iter()
            .enumerate()
            .map(|ip| {
                let l = lum(ip);
                if l < 0.0 { UNPAINTED } else { ((l * scale).min(1.0).sqrt() * top + 0.5) as u32 }
            })
            .collect();
        let mut histogram = vec![0u32; KEY_LEVELS];
        let mut total = 0u64;
        for &k in &keys {
            if k != UNPAINTED {
                histogram[k as usize] += 1;
                total += 1;
            }
        }
        LuminanceKeys { keys, histogram, total }
    }
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_passage;
#[cfg(test)]
mod tests_plane;
