//! A render session (issue 14): the scene, its BVH and per-mesh saliency, and every stage's
//! output kept between renders, each keyed by exactly the inputs that stage reads, so a new
//! render re-runs only the stages a change invalidates. `cubist serve` keeps one per process;
//! the frames of an animation (same settings, another pose or camera) can drive one the same
//! way. `pipeline::render` runs the very same sequence with nothing kept, so a kept output
//! gives the pixels a fresh render gives (tests/session.rs checks it at every level).
//!
//! Each output gets a generation number; a stage's key holds its own parameters and the
//! generations of the outputs it read:
//!
//! | output | keyed by |
//! |---|---|
//! | scene (`Prepared`) | the scene's content (`fingerprints`); its BVH by the placed triangles alone; per-mesh saliency by mesh content (`saliency::Memo`) |
//! | pre-render | scene, `FramingParams`, `TraceParams` |
//! | saliency map | pre-render, saliency method |
//! | facet layout and map | `FacetParams`, its files' contents; pre-render and saliency map when the method reads the picture |
//! | aims | layout, pre-render, saliency map when the mode reads it, `AimParams` |
//! | re-trace | aims (kept as the moved pixels only, swapped into the pre-render's film when read) |
//! | anti-aliasing | re-trace (or pre-render), layout, aims (kept as the refined pixels' colours) |
//! | painter | `PaintParams`, the palette painting's contents |
//! | paint | anti-aliasing (or re-trace, or pre-render), layout, painter, lights (pre-render) |
//! | encoded images | paint, layout, aims, saliency map, passes, background, transparency |
//!
//! So a painterly change re-runs paint (and encoding) only; a facet change faceting onwards; a
//! camera or image change the pre-render onwards; a new scene only what its changed meshes
//! need (saliency of the changed meshes; the BVH while the two-level BVH is not in, see
//! `set_scene`). Outputs are kept per image size ("lanes", most recent first, at most
//! `LANES`, within `budget` bytes): the viewport's 1/4, 1/2 and full-size passes and F12 each
//! keep theirs.

use std::collections::VecDeque;
use std::path::Path;
use std::time::Instant;

use glam::Vec4;
use image::RgbaImage;
use serde::Serialize;
use xxhash_rust::xxh3::Xxh3;

use super::{
    PreRender, Prepared, Shading, Stage, StageParams, Timings, aim_context, aims_stage_traced, antialias_stage,
    encode_stage, layout_stage, moved_pixels, prerender, retrace_stage, saliency_stage, shade_stage,
};
use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::facets::{self, FacetLayout, FacetMap, FacetMethod, FacetParams};
use crate::film::{Film, PixelHit, SampleHit};
use crate::imprecision::{self, AimMode, AimParams, FacetAim};
use crate::output::{Gray16, Pass};
use crate::paint::chiaroscuro::ViewAxes;
use crate::paint::{Lighting, PaintInputs, PaintParams, Painter, Resume};
use crate::progress::Progress;
use crate::saliency::{self, SaliencyMethod};
use crate::scene::{LoadOptions, Scene, World};
use crate::settings::Settings;
use crate::trace::TraceParams;

/// Image sizes whose outputs are kept: the viewport's three progressive passes and F12's.
pub const LANES: usize = 4;
/// Memory the kept outputs may use by default, bytes; the lane in use is always kept.
pub const DEFAULT_BUDGET: u64 = 3 << 30;

/// Names one stage output (unique within a session).
type Gen = u64;

struct Entry<K, V> {
    key: K,
    id: Gen,
    value: V,
}

fn hit<K: PartialEq, V>(slot: &Option<Entry<K, V>>, key: &K) -> bool {
    slot.as_ref().is_some_and(|e| e.key == *key)
}

fn gen_of<K, V>(slot: &Option<Entry<K, V>>) -> Gen {
    slot.as_ref().map_or(0, |e| e.id)
}

#[derive(PartialEq)]
struct PreKey {
    scene: Gen,
    framing: crate::camera::FramingParams,
    trace: TraceParams,
}

#[derive(Clone, Copy, PartialEq)]
struct SalKey {
    pre: Gen,
    method: SaliencyMethod,
}

#[derive(PartialEq)]
struct LayoutKey {
    params: FacetParams,
    /// Contents of the layout file and the facet map image.
    files: [Option<u128>; 2],
    /// The pre-render and saliency map, for methods that follow the picture.
    picture: Option<(Gen, Option<Gen>)>,
}

#[derive(PartialEq)]
struct AimKey {
    layout: Gen,
    pre: Gen,
    saliency: Option<Gen>,
    params: AimParams,
}

#[derive(PartialEq)]
struct AaKey {
    /// The film refined: the re-trace's, or the pre-render's.
    film: Gen,
    layout: Gen,
    aims: Option<Gen>,
}

#[derive(PartialEq)]
struct PainterKey {
    params: PaintParams,
    palette: Option<u128>,
}

#[derive(PartialEq)]
struct PaintKey {
    /// The film painted: the re-trace's, or the pre-render's when no facet moved.
    film: Gen,
    layout: Option<Gen>,
    painter: Gen,
    /// The lights chiaroscuro relights with.
    pre: Gen,
}

/// What the painted canvas kept part-way through the chain (`Prefix`) was painted over: the
/// film, the facet map, the lights, the palette painting's contents.
#[derive(Clone, PartialEq)]
struct PrefixKey {
    film: Gen,
    layout: Option<Gen>,
    pre: Gen,
    palette: Option<u128>,
}

/// The effect keys of the last chain painted over a `PrefixKey`, and the canvas before the
/// first effect that changed then (the effects before it agreed with the chain before): a
/// paint-only change of one effect runs again from that effect on.
struct Prefix {
    keys: Vec<String>,
    /// Effects done, and the canvas after them.
    snapshot: Option<(usize, Vec<Vec4>)>,
}

#[derive(PartialEq)]
struct EncodeKey {
    /// The colour encoded: the paint's, else the film's.
    colour: Gen,
    film: Gen,
    layout: Gen,
    aims: Option<Gen>,
    saliency: Option<Gen>,
    passes: Vec<Pass>,
    background: [f32; 3],
    transparent: bool,
    neighbourhood: f64,
    scale: f64,
}

/// What the planes faceting's kept inputs were made from: the pre-render, the saliency map,
/// whether outlines are cut.
type PlanesKey = (Gen, Option<Gen>, bool);

struct LayoutOut {
    layout: FacetLayout,
    map: FacetMap,
    warnings: Vec<String>,
}

/// The re-trace's output: the moved facets' pixels as traced again. Kept apart from the
/// pre-render's film and swapped into it while a later stage reads it (swapping twice leaves
/// the film as it was), so a facet change copies the moved pixels, not the whole film.
#[derive(Default)]
struct Delta {
    pixels: Vec<u32>,
    color: Vec<Vec4>,
    hits: Vec<PixelHit>,
    occlusion: Vec<u8>,
    samples: Vec<SampleHit>,
    /// What the pixels were traced through (a session's; the next re-trace reuses the pixels
    /// whose rays and facet neighbours are the same, `Traced::same`).
    traced: Option<std::sync::Arc<Traced>>,
}

/// A facet's rays as a trace reads them: None for the camera's (not moved), else its re-aim.
type FacetRays = Option<(Option<imprecision::Reaim>, Option<imprecision::Linear>)>;

fn facet_rays_of(aim: &FacetAim) -> FacetRays {
    aim.moved().then_some((aim.reaim, aim.linear))
}

/// The facet map and each facet's rays a re-trace and an anti-aliasing traced through, and
/// the pre-render they traced over.
struct Traced {
    pre: Gen,
    ids: Vec<u32>,
    rays: Vec<FacetRays>,
}

impl Traced {
    fn new(pre: Gen, map: &FacetMap, aims: &[FacetAim]) -> Traced {
        Traced { pre, ids: map.ids.clone(), rays: aims.iter().map(facet_rays_of).collect() }
    }

    fn rays_at(&self, i: usize) -> FacetRays {
        self.rays.get(self.ids[i] as usize).copied().flatten()
    }

    /// Whether some pixel can be traced through the same moved rays in `self` and `new`
    /// (`same`): over the same pre-render, some facet of `new` re-aimed as a facet of `self`
    /// was. When none is (another plane detail, a camera change), no pixel need be compared.
    fn may_share_rays(&self, new: &Traced) -> bool {
        if self.pre != new.pre || self.ids.len() != new.ids.len() {
            return false;
        }
        let old: Vec<&FacetRays> = self.rays.iter().filter(|r| r.is_some()).collect();
        // Many facets (a fine Segment layout): the pixels are compared instead.
        if old.len().saturating_mul(new.rays.len()) > 1 << 22 {
            return true;
        }
        new.rays.iter().filter(|r| r.is_some()).any(|r| old.contains(&r))
    }

    /// Whether pixel `i` is traced through the same rays in `self` and `new`, and each of
    /// `neighbours` shares its facet in both or in neither: a re-trace or anti-aliasing then
    /// gives it the same result (its rays, and what it reads of the pixels around it through
    /// the facet map: the coarse shadow grid, `trace::Tracer::render`; for anti-aliasing the
    /// occlusion the neighbours agree on is compared too).
    fn same(&self, new: &Traced, i: usize, neighbours: impl Iterator<Item = usize>) -> bool {
        if self.pre != new.pre || self.ids.len() != new.ids.len() || self.rays_at(i) != new.rays_at(i) {
            return false;
        }
        let (a, b) = (self.ids[i], new.ids[i]);
        neighbours.into_iter().all(|j| (self.ids[j] == a) == (new.ids[j] == b))
    }
}

impl Delta {
    /// `pixels`' current colour, hits and samples in `film`.
    fn gather(film: &Film, pixels: Vec<u32>) -> Delta {
        use rayon::prelude::*;
        // In parallel, in the pixels' order (rayon's collect keeps it).
        let ((color, hits), (occlusion, samples)) = rayon::join(
            || {
                rayon::join(
                    || pixels.par_iter().map(|&i| film.color[i as usize]).collect(),
                    || pixels.par_iter().map(|&i| film.hits[i as usize]).collect(),
                )
            },
            || {
                rayon::join(
                    || pixels.par_iter().map(|&i| film.occlusion[i as usize]).collect(),
                    || pixels.par_iter().flat_map_iter(|&i| film.pixel_samples(i as usize).iter().copied()).collect(),
                )
            },
        );
        Delta { color, hits, occlusion, samples, pixels, traced: None }
    }

    /// Copies pixel `k` of `self` (as traced) into `film` at `i`.
    fn put(&self, k: usize, film: &mut Film, i: usize) {
        let spp = film.spp as usize;
        film.color[i] = self.color[k];
        film.hits[i] = self.hits[k];
        film.occlusion[i] = self.occlusion[k];
        film.samples[i * spp..(i + 1) * spp].copy_from_slice(&self.samples[k * spp..(k + 1) * spp]);
    }

    /// Exchanges the delta's pixels with the film's.
    fn swap(&mut self, film: &mut Film) {
        self.swap_read(film, Reads::All);
    }

    /// Exchanges the delta's pixels with the film's in the buffers a stage reads (`Reads`):
    /// swapping twice leaves the film as it was either way. The colour and hits on one
    /// thread, the occlusion and samples on another (disjoint buffers).
    fn swap_read(&mut self, film: &mut Film, reads: Reads) {
        let spp = film.spp as usize;
        let Delta { pixels, color, hits, occlusion, samples, .. } = self;
        let Film { color: film_color, hits: film_hits, occlusion: film_occlusion, samples: film_samples, .. } = film;
        let pixels = &*pixels;
        rayon::join(
            || {
                for (k, &i) in pixels.iter().enumerate() {
                    let i = i as usize;
                    std::mem::swap(&mut color[k], &mut film_color[i]);
                    std::mem::swap(&mut hits[k], &mut film_hits[i]);
                }
            },
            || {
                if reads == Reads::ColourAndHits {
                    return;
                }
                for (k, &i) in pixels.iter().enumerate() {
                    let i = i as usize;
                    std::mem::swap(&mut occlusion[k], &mut film_occlusion[i]);
                    samples[k * spp..(k + 1) * spp].swap_with_slice(&mut film_samples[i * spp..(i + 1) * spp]);
                }
            },
        );
    }

    fn bytes(&self) -> u64 {
        (self.pixels.len() * 4
            + self.traced.as_ref().map_or(0, |t| t.ids.len() * 4)
            + self.color.len() * size_of::<Vec4>()
            + self.hits.len() * size_of::<PixelHit>()
            + self.occlusion.len()
            + self.samples.len() * size_of::<SampleHit>()) as u64
    }
}

/// The anti-aliasing's output: the refined pixels' colours, swapped into the film (over the
/// re-trace's delta) while a later stage reads it, like `Delta`.
#[derive(Default)]
struct ColourDelta {
    pixels: Vec<u32>,
    color: Vec<Vec4>,
    /// A session's: each pixel's `trace::antialias_known`, and the rays it was refined
    /// through (the next anti-aliasing reuses the pixels refined again through the same rays
    /// with the same lights known).
    known: Vec<u64>,
    traced: Option<std::sync::Arc<Traced>>,
}

impl ColourDelta {
    fn swap(&mut self, film: &mut Film) {
        for (k, &i) in self.pixels.iter().enumerate() {
            std::mem::swap(&mut self.color[k], &mut film.color[i as usize]);
        }
    }

    fn bytes(&self) -> u64 {
        (self.pixels.len() * 4 + self.color.len() * size_of::<Vec4>() + self.known.len() * 8) as u64
            + self.traced.as_ref().map_or(0, |t| t.ids.len() as u64 * 4)
    }
}

/// Which of the film's per-pixel buffers a stage reads (`with_film`).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Reads {
    All,
    /// The paint reads the colour and the hits alone (`Painter::apply_from`).
    ColourAndHits,
}

/// Runs `f` on the film as the stages after the re-trace see it: the moved pixels swapped in
/// (in the buffers `f` `reads`) and, when given, the painted colour; both are swapped back out
/// afterwards, whatever `f` returns.
fn with_film<T>(
    film: &mut Film,
    reads: Reads,
    mut delta: Option<&mut Delta>,
    mut aa: Option<&mut ColourDelta>,
    mut colour: Option<&mut Vec<Vec4>>,
    f: impl FnOnce(&mut Film) -> T,
) -> T {
    if let Some(d) = delta.as_deref_mut() {
        d.swap_read(film, reads);
    }
    if let Some(a) = aa.as_deref_mut() {
        a.swap(film);
    }
    if let Some(c) = colour.as_deref_mut() {
        std::mem::swap(&mut film.color, c);
    }
    let out = f(film);
    if let Some(c) = colour {
        std::mem::swap(&mut film.color, c);
    }
    if let Some(a) = aa {
        a.swap(film);
    }
    if let Some(d) = delta {
        d.swap_read(film, reads);
    }
    out
}

#[derive(Clone)]
struct Encoded {
    image: RgbaImage,
    passes: Vec<(Pass, RgbaImage)>,
    passes16: Vec<(Pass, Gray16)>,
}

/// The kept outputs of one image size.
pub(super) struct Lane {
    size: (u32, u32),
    /// False for a one-off render (`pipeline::render`): nothing is copied to be kept.
    keep: bool,
    pre: Option<Entry<PreKey, PreRender>>,
    saliency: Option<Entry<SalKey, Vec<f32>>>,
    /// What the planes faceting reads of the pre-render whatever its plane count and detail
    /// (keyed by the pre-render, the saliency map and whether outlines are cut).
    planes: Option<Entry<PlanesKey, facets::planes::Prepared>>,
    layout: Option<Entry<LayoutKey, LayoutOut>>,
    aims: Option<Entry<AimKey, Vec<FacetAim>>>,
    retrace: Option<Entry<Gen, Delta>>,
    aa: Option<Entry<AaKey, ColourDelta>>,
    painter: Option<Entry<PainterKey, Painter>>,
    /// The paint inputs (regions, planes, edges) of a film (the re-trace's) and facet map.
    paint_inputs: Option<Entry<(Gen, Option<Gen>), PaintInputs>>,
    paint_prefix: Option<Entry<PrefixKey, Prefix>>,
    paint: Option<Entry<PaintKey, Vec<Vec4>>>,
    encoded: Option<Entry<EncodeKey, Encoded>>,
}

impl Lane {
    pub(super) fn new(width: u32, height: u32, keep: bool) -> Lane {
        Lane {
            size: (width, height),
            keep,
            pre: None,
            saliency: None,
            planes: None,
            layout: None,
            aims: None,
            retrace: None,
            aa: None,
            painter: None,
            paint_inputs: None,
            paint_prefix: None,
            paint: None,
            encoded: None,
        }
    }

    /// Bytes held (the buffers; the small structures around them are not counted).
    fn bytes(&self) -> u64 {
        let film = |f: &Film| {
            (f.color.len() * size_of::<Vec4>()
                + f.hits.len() * size_of::<PixelHit>()
                + f.occlusion.len()
                + f.samples.len() * size_of::<SampleHit>()
                + f.saliency.as_ref().map_or(0, |s| s.len() * 4)) as u64
        };
        let image = |i: &RgbaImage| i.as_raw().len() as u64;
        self.pre.as_ref().map_or(0, |e| film(&e.value.film))
            + self.saliency.as_ref().map_or(0, |e| e.value.len() as u64 * 4)
            + self.planes.as_ref().map_or(0, |e| e.value.bytes())
            + self.layout.as_ref().map_or(0, |e| e.value.map.ids.len() as u64 * 4)
            + self.retrace.as_ref().map_or(0, |e| e.value.bytes())
            + self.aa.as_ref().map_or(0, |e| e.value.bytes())
            + self.paint_inputs.as_ref().map_or(0, |e| e.value.bytes())
            + self
                .paint_prefix
                .as_ref()
                .map_or(0, |e| e.value.snapshot.as_ref().map_or(0, |(_, px)| (px.len() * size_of::<Vec4>()) as u64))
            + self.paint.as_ref().map_or(0, |e| (e.value.len() * size_of::<Vec4>()) as u64)
            + self.encoded.as_ref().map_or(0, |e| {
                image(&e.value.image)
                    + e.value.passes.iter().map(|(_, i)| image(i)).sum::<u64>()
                    + e.value.passes16.iter().map(|(_, i)| i.as_raw().len() as u64 * 2).sum::<u64>()
            })
    }

    /// The outputs held, by stage name.
    fn held(&self) -> Vec<&'static str> {
        let slots = [
            (Stage::PreRender.name(), self.pre.is_some()),
            (Stage::Saliency.name(), self.saliency.is_some()),
            ("faceting inputs", self.planes.is_some()),
            (Stage::Faceting.name(), self.layout.is_some()),
            (Stage::Imprecision.name(), self.aims.is_some()),
            (Stage::ReTrace.name(), self.retrace.is_some()),
            (Stage::AntiAliasing.name(), self.aa.is_some()),
            ("paint setup", self.painter.is_some()),
            ("paint inputs", self.paint_inputs.is_some()),
            ("paint prefix", self.paint_prefix.as_ref().is_some_and(|e| e.value.snapshot.is_some())),
            (Stage::Paint.name(), self.paint.is_some()),
            ("encode", self.encoded.is_some()),
        ];
        slots.into_iter().filter(|(_, held)| *held).map(|(name, _)| name).collect()
    }

    /// The final film of a one-off render (what `Rendered` holds): the pre-render's film with
    /// the re-traced pixels, the painted colour and the saliency map; the facet map; the aims.
    pub(super) fn into_products(mut self) -> Result<(Film, FacetMap, FacetLayout, Vec<FacetAim>)> {
        let missing = || Error::Internal("a render's outputs are missing".into());
        let mut film = self.pre.take().ok_or_else(missing)?.value.film;
        if let Some(mut d) = self.retrace.take() {
            d.value.swap(&mut film);
        }
        if let Some(mut a) = self.aa.take() {
            a.value.swap(&mut film);
        }
        if let Some(p) = self.paint.take().filter(|p| !p.value.is_empty()) {
            film.color = p.value;
        }
        film.saliency = self.saliency.take().map(|e| e.value).filter(|v| !v.is_empty());
        let LayoutOut { layout, map, .. } = self.layout.take().ok_or_else(missing)?.value;
        Ok((film, map, layout, self.aims.take().map(|e| e.value).unwrap_or_default()))
    }
}

/// What a render gives back.
pub struct Frame {
    pub image: RgbaImage,
    pub passes: Vec<(Pass, RgbaImage)>,
    /// Passes stored as 16-bit grey (facet ids).
    pub passes16: Vec<(Pass, Gray16)>,
    /// The steps that ran, and their times (kept outputs are not listed).
    pub timings: Timings,
    pub warnings: Vec<String>,
    /// One line saying which camera was used and where its focal centre is.
    pub camera: String,
    /// The steps whose output was kept from an earlier render, in pipeline order.
    pub reused: Vec<&'static str>,
    /// Pixels the re-trace and the anti-aliasing took from the previous render's instead of
    /// tracing them again (zero when the stage did not run or kept nothing).
    pub pixels_kept: PixelsKept,
}

/// How many pixels a facet change's re-trace and anti-aliasing kept from the previous render
/// (traced through the same rays, reading the same neighbours) and traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelsKept {
    pub retrace_kept: usize,
    pub retrace_traced: usize,
    pub antialiasing_kept: usize,
    pub antialiasing_traced: usize,
}

/// Hash of a file's bytes (None when it cannot be read: the stage reading it reports why).
fn file_key(path: Option<&Path>) -> Option<u128> {
    path.and_then(|p| hash_file(p, |_| {})).map(|h| h.digest128())
}

/// Streams a regular file's bytes into a hash, `each` seeing every chunk. None for a file that
/// cannot be read or is not a regular file: a FIFO or a device is refused without blocking
/// (`open_regular`), and its reader then says why.
fn hash_file(path: &Path, mut each: impl FnMut(&[u8])) -> Option<Xxh3> {
    use std::io::Read;
    let (mut f, _) = crate::util::files::open_regular(path, u64::MAX).ok()?;
    let mut hasher = Xxh3::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).ok()?;
        if n == 0 {
            return Some(hasher);
        }
        each(&buf[..n]);
        hasher.update(&buf[..n]);
    }
}

/// Whether a faceting method reads the pre-render (its layout follows the picture). An
/// exhaustive match: a new method must say.
fn reads_picture(params: &FacetParams) -> bool {
    if params.layout_file.is_some() {
        return false;
    }
    match params.method {
        FacetMethod::Segment | FacetMethod::Planes => true,
        FacetMethod::None | FacetMethod::Constant | FacetMethod::Voronoi | FacetMethod::Patch => false,
    }
}

/// A hook on the film once the saliency map is in (`render_with`).
pub(super) type AfterSaliency<'a> = dyn Fn(&Prepared, &mut Film) + 'a;

/// The stages of one render (SPEC Fig. 4.1, in `render`'s order), each run only when its key
/// differs from the output `lane` holds. `after_saliency` (one-off renders only: tests supply a
/// known saliency map with it) sees the film once the saliency map is in.
pub(super) fn run(
    prep: &Prepared,
    scene: Gen,
    lane: &mut Lane,
    gens: &mut Gen,
    params: &StageParams,
    progress: &Progress,
    after_saliency: Option<&AfterSaliency<'_>>,
) -> Result<Frame> {
    super::check_work(params)?;
    let plan = super::Plan::new(params);
    let mut next = || {
        *gens += 1;
        *gens
    };
    let mut timings = Timings::default();
    let mut reused = Vec::new();

    // The painter first, so a bad palette image fails before the long part.
    let painter_key =
        PainterKey { params: params.paint.clone(), palette: file_key(params.paint.palette_image.as_deref()) };
    if !hit(&lane.painter, &painter_key) {
        lane.painter = None;
        let painter = timings.time("paint setup", || Painter::new(&params.paint))?;
        lane.painter = Some(Entry { key: painter_key, id: next(), value: painter });
    }

    let pre_key = PreKey { scene, framing: params.framing.clone(), trace: params.trace.clone() };
    if hit(&lane.pre, &pre_key) {
        reused.push(Stage::PreRender.name());
    } else {
        // Everything traced before is stale: freed before tracing, for a lower peak.
        lane.pre = None;
        lane.planes = None;
        lane.retrace = None;
        lane.aa = None;
        lane.paint_inputs = None;
        lane.paint_prefix = None;
        lane.paint = None;
        lane.encoded = None;
        // perf6 (issue 16): a one-off render whose stages before the re-trace read no colour
        // shades only the pixels the re-trace keeps, after the aims (`shade_stage`).
        let deferred = !lane.keep
            && after_saliency.is_none()
            && plan.imprecision
            && !(reads_picture(&params.facets) && params.facets.method == FacetMethod::Segment);
        let shading = if deferred { Shading::Deferred } else { Shading::Lit };
        let pre = if plan.saliency {
            // Mesh saliency reads only the meshes: it runs beside framing and the pre-render
            // (timed on its own, by wall clock; their CPU figures then include its work).
            let (pre, mesh_time) = rayon::join(
                || prerender(prep, &params.framing, &params.trace, shading, progress, &mut timings),
                || {
                    let t = std::time::Instant::now();
                    crate::saliency::precompute(&prep.scene, &prep.world, &prep.saliency, &params.saliency);
                    t.elapsed()
                },
            );
            timings.0.push((super::stage::MESH_SALIENCY_OVERLAPPED, mesh_time));
            timings.1.push(None);
            pre?
        } else {
            prerender(prep, &params.framing, &params.trace, shading, progress, &mut timings)?
        };
        progress.check()?;
        lane.pre = Some(Entry { key: pre_key, id: next(), value: pre });
    }
    let pre_gen = gen_of(&lane.pre);

    let sal_key = SalKey { pre: pre_gen, method: params.saliency.method };
    if plan.saliency {
        if hit(&lane.saliency, &sal_key) {
            reused.push(Stage::Saliency.name());
        } else {
            lane.saliency = None;
            let film = &lane.pre.as_ref().expect("pre-render just made").value.film;
            let (_, map) = saliency_stage(prep, film, &params.saliency, progress, &mut timings)?;
            progress.check()?;
            lane.saliency = Some(Entry { key: sal_key, id: next(), value: map });
        }
    }
    let mut pre = lane.pre.take().expect("pre-render just made");
    // The saliency map is lent to the film while the later stages read it.
    let mut sal = if plan.saliency { lane.saliency.take() } else { None };
    pre.value.film.saliency = sal.as_mut().map(|e| std::mem::take(&mut e.value));
    if let Some(hook) = after_saliency {
        hook(prep, &mut pre.value.film);
        if sal.is_none() && pre.value.film.saliency.is_some() {
            sal = Some(Entry { key: sal_key, id: next(), value: Vec::new() });
        }
    }
    let sal_gen = sal.as_ref().map(|e| e.id);
    let result = after_saliency_stages(prep, lane, &mut pre, sal_gen, params, &plan, progress, &mut next, &mut timings);
    // Back in the lane, whatever happened (a cancel keeps what was done).
    if let Some(e) = sal.as_mut() {
        e.value = pre.value.film.saliency.take().unwrap_or_default();
    }
    pre.value.film.saliency = None;
    if sal.is_some() {
        lane.saliency = sal;
    }
    lane.pre = Some(pre);
    let (encoded, warnings, camera, mut later, pixels_kept) = result?;
    reused.append(&mut later);
    Ok(Frame {
        image: encoded.image,
        passes: encoded.passes,
        passes16: encoded.passes16,
        timings,
        warnings,
        camera,
        reused,
        pixels_kept,
    })
}

/// What the stages from faceting on give: the encoded images, warnings, the camera in words,
/// the steps reused and the pixels kept.
type LaterStages = (Encoded, Vec<String>, String, Vec<&'static str>, PixelsKept);

/// `run` from faceting on, with the pre-render (its film holding the saliency map, if any)
/// taken out of the lane.
#[allow(clippy::too_many_arguments)]
fn after_saliency_stages(
    prep: &Prepared,
    lane: &mut Lane,
    pre: &mut Entry<PreKey, PreRender>,
    sal_gen: Option<Gen>,
    params: &StageParams,
    plan: &super::Plan,
    progress: &Progress,
    next: &mut dyn FnMut() -> Gen,
    timings: &mut Timings,
) -> Result<LaterStages> {
    let mut reused = Vec::new();
    let mut pixels_kept = PixelsKept::default();
    let pre_gen = pre.id;
    let PreRender { film, view, warnings: pre_warnings, unshaded } = &mut pre.value;
    let mut warnings = pre_warnings.clone();

    let reads = reads_picture(&params.facets);
    let layout_key = LayoutKey {
        params: params.facets.clone(),
        files: [file_key(params.facets.layout_file.as_deref()), file_key(params.facets.facet_map.as_deref())],
        picture: reads.then_some((pre_gen, sal_gen)),
    };
    if hit(&lane.layout, &layout_key) {
        if plan.faceting {
            reused.push(Stage::Faceting.name());
        }
    } else {
        let old = lane.layout.take();
        let mut w = Vec::new();
        let (layout, map) = if params.facets.method == FacetMethod::Planes
            && params.facets.layout_file.is_none()
            && (film.width, film.height) == (params.facets.width, params.facets.height)
        {
            // The planes from what they read of the pre-render whatever their count and
            // detail (the density's cues, the outlines), made once per pre-render.
            let key = (pre_gen, sal_gen, params.facets.planes.outlines);
            let planes = &mut lane.planes;
            progress.begin(Stage::Faceting.name(), 1);
            timings.time(Stage::Faceting.name(), || {
                let input = facets::planes::PlanesInput {
                    width: film.width,
                    height: film.height,
                    hits: &film.hits,
                    saliency: film.saliency.as_deref(),
                };
                if !hit(planes, &key) {
                    let value = facets::planes::prepare(&input, key.2);
                    *planes = Some(Entry { key, id: next(), value });
                }
                let prep = &planes.as_ref().expect("just made").value;
                facets::planes::layout_prepared(&input, &params.facets.planes, prep)
            })
        } else {
            layout_stage(&params.facets, film, progress, timings, &mut w)?
        };
        progress.check()?;
        // The later stages read the facet map alone (a saved layout is written from the new
        // one): a change that gives the same map (a setting the method does not read) keeps
        // their outputs.
        let id = match old {
            Some(o) if o.value.map == map => o.id,
            _ => next(),
        };
        lane.layout = Some(Entry { key: layout_key, id, value: LayoutOut { layout, map, warnings: w } });
    }
    let layout_gen = gen_of(&lane.layout);
    let out = &lane.layout.as_ref().expect("layout just made").value;
    warnings.extend(out.warnings.iter().cloned());
    let map = &out.map;

    // Saliency centres count pixels within `neighborhood` of a facet: bounded work, or an error.
    if plan.faceting && params.aim.neighborhood > 0.0 && film.saliency.is_some() {
        imprecision::check_neighbourhood(map, params.aim.neighbourhood_px())?;
    }

    // Spatial imprecision (SPEC "Spatial imprecision"): re-aim facets, re-trace only the pixels
    // of facets whose rays changed; at discontinuity 0 with converging facets nothing runs.
    let mut aims_gen = None;
    // The cue check's centre hits, for this run's re-trace only (then dropped).
    let mut centre = None;
    if plan.imprecision {
        if params.aim.reads_saliency() && film.saliency.is_none() {
            warnings.push("no saliency map was computed: facets are not re-aimed (imprecision saliency)".into());
        }
        let ctx = aim_context(prep, view, &params.trace);
        let saliency = if params.aim.mode == AimMode::Saliency { sal_gen } else { None };
        let key = AimKey { layout: layout_gen, pre: pre_gen, saliency, params: params.aim.clone() };
        if hit(&lane.aims, &key) {
            reused.push(Stage::Imprecision.name());
        } else {
            lane.aims = None;
            let (aims, hits) =
                aims_stage_traced(&ctx, map, film, &params.aim, Some((prep, &params.saliency)), progress, timings);
            progress.check()?;
            lane.aims = Some(Entry { key, id: next(), value: aims });
            centre = hits;
        }
        let aims = &lane.aims.as_ref().expect("aims just made").value;
        let id = gen_of(&lane.aims);
        aims_gen = Some(id);
        if hit(&lane.retrace, &id) {
            if !lane.retrace.as_ref().is_some_and(|e| e.value.pixels.is_empty()) {
                reused.push(Stage::ReTrace.name());
            }
        } else {
            let old = lane.retrace.take();
            // The originals, then the re-trace in place, then swapped: the film is the
            // pre-render's again and the delta holds the moved pixels as traced again. A
            // one-off render keeps no originals (no copy of the moved pixels'
            // samples: tests/memory_bound.rs): its film holds the re-trace, the delta nothing.
            let moved = moved_pixels(map, aims);
            let delta = if lane.keep {
                let mut delta = Delta::gather(film, moved);
                let traced = std::sync::Arc::new(Traced::new(pre_gen, map, aims));
                // Pixels the previous re-trace traced through the same rays, reading the same
                // neighbours: put back as they were; the others traced again.
                let (w, h) = (film.width as usize, film.height as usize);
                let mut again = Vec::with_capacity(delta.pixels.len());
                let old = old
                    .as_ref()
                    .and_then(|e| e.value.traced.as_ref().map(|t| (&e.value, t)))
                    .filter(|(_, t)| t.may_share_rays(&traced));
                match old {
                    None => again.extend_from_slice(&delta.pixels),
                    Some((d, t)) => {
                        let mut k = 0;
                        for &i in &delta.pixels {
                            while k < d.pixels.len() && d.pixels[k] < i {
                                k += 1;
                            }
                            let around = crate::trace::coarse_grid_around(w, h, i as usize);
                            if d.pixels.get(k) == Some(&i) && t.same(&traced, i as usize, around) {
                                d.put(k, film, i as usize);
                            } else {
                                again.push(i);
                            }
                        }
                    }
                }
                pixels_kept.retrace_kept = delta.pixels.len() - again.len();
                pixels_kept.retrace_traced = again.len();
                if !again.is_empty() {
                    retrace_stage(
                        prep,
                        view,
                        &ctx,
                        &params.trace,
                        map,
                        aims,
                        &again,
                        centre.take().as_ref(),
                        film,
                        progress,
                        timings,
                    );
                }
                delta.swap(film);
                progress.check()?;
                delta.traced = Some(traced);
                delta
            } else {
                if std::mem::take(unshaded) {
                    // perf6 (issue 16): the pixels the re-trace keeps, shaded now.
                    shade_stage(prep, view, &ctx, &params.trace, &moved, film, progress, timings);
                    progress.check()?;
                }
                if !moved.is_empty() {
                    retrace_stage(
                        prep,
                        view,
                        &ctx,
                        &params.trace,
                        map,
                        aims,
                        &moved,
                        centre.take().as_ref(),
                        film,
                        progress,
                        timings,
                    );
                    progress.check()?;
                }
                Delta::default()
            };
            lane.retrace = Some(Entry { key: id, id: next(), value: delta });
        }
    }
    let traced_gen = if plan.imprecision { gen_of(&lane.retrace) } else { pre_gen };
    let mut delta = if plan.imprecision { lane.retrace.as_mut().map(|e| &mut e.value) } else { None };

    // Anti-aliasing: `spp` samples where the single centre samples say the picture has an
    // edge. Kept as the refined pixels' colours (a one-off render refines in place).
    let mut film_gen = traced_gen;
    if plan.antialiasing {
        let key = AaKey { film: traced_gen, layout: layout_gen, aims: aims_gen };
        if hit(&lane.aa, &key) {
            reused.push(Stage::AntiAliasing.name());
        } else {
            let old = lane.aa.take();
            let ctx = aim_context(prep, view, &params.trace);
            let aims: &[FacetAim] = match (&lane.aims, aims_gen) {
                (Some(e), Some(_)) => &e.value,
                _ => &[],
            };
            let keep = lane.keep;
            let traced = delta
                .as_ref()
                .and_then(|d| d.traced.clone())
                .unwrap_or_else(|| std::sync::Arc::new(Traced::new(pre_gen, map, aims)));
            let refined = with_film(film, Reads::All, delta.as_deref_mut(), None, None, |film| {
                if !keep {
                    antialias_stage(prep, view, &ctx, &params.trace, map, aims, film, progress, timings);
                    return ColourDelta::default();
                }
                // The previous anti-aliasing's colour of a pixel refined again through the
                // same rays with the same lights known (`Traced::same`; what it reads of its
                // neighbours is in `known`).
                let old = old.as_ref().and_then(|e| e.value.traced.as_ref().map(|t| (&e.value, t)));
                // Each pixel's place in the previous refined list, plus one (0: not refined).
                let at = old.map(|(o, _)| {
                    let mut at = vec![0u32; film.pixel_count()];
                    for (k, &i) in o.pixels.iter().enumerate() {
                        at[i as usize] = k as u32 + 1;
                    }
                    at
                });
                let reuse = |i: u32, known: u64| -> Option<Vec4> {
                    let ((o, t), at) = old.zip(at.as_ref())?;
                    let k = at[i as usize].checked_sub(1)? as usize;
                    (o.known[k] == known && t.same(&traced, i as usize, std::iter::empty())).then(|| o.color[k])
                };
                let (pixels, known, color, traced_count) = super::antialias_reusing(
                    prep,
                    view,
                    &ctx,
                    &params.trace,
                    map,
                    aims,
                    film,
                    &reuse,
                    progress,
                    timings,
                );
                pixels_kept.antialiasing_kept = pixels.len() - traced_count;
                pixels_kept.antialiasing_traced = traced_count;
                ColourDelta { pixels, color, known, traced: Some(traced.clone()) }
            });

            progress.check()?;
            lane.aa = Some(Entry { key, id: next(), value: refined });
        }
        film_gen = gen_of(&lane.aa);
    }
    let mut aa = if plan.antialiasing { lane.aa.as_mut().map(|e| &mut e.value) } else { None };

    let mut colour_gen = film_gen;
    if plan.paint {
        let painter = lane.painter.as_ref().expect("painter just made");
        let key =
            PaintKey { film: film_gen, layout: plan.faceting.then_some(layout_gen), painter: painter.id, pre: pre_gen };
        if hit(&lane.paint, &key) {
            reused.push(Stage::Paint.name());
        } else {
            lane.paint = None;
            // An unfaceted image has no facet borders or corners: no facet map for the painter.
            let f = &view.framed.frame;
            let axes = ViewAxes { right: f.right.as_vec3(), up: f.up.as_vec3(), forward: f.forward.as_vec3() };
            let lighting = view.rig.as_ref().map(|rig| Lighting { world: &prep.world, rig, view: axes });
            let facets = plan.faceting.then_some(map);
            progress.begin(Stage::Paint.name(), 1);
            let keep = lane.keep;
            // What the effects derive from the film's hits and the facet map alone.
            let inputs_key = (traced_gen, plan.faceting.then_some(layout_gen));
            if !keep || !hit(&lane.paint_inputs, &inputs_key) {
                // (A one-off render paints once: its edges are made at the border width alone.)
                let old = lane.paint_inputs.take();
                let value = if keep {
                    PaintInputs::kept_for_changes_after(old.as_ref().map(|e| &e.value))
                } else {
                    PaintInputs::kept()
                };
                lane.paint_inputs = Some(Entry { key: inputs_key, id: next(), value });
            }
            let inputs = &lane.paint_inputs.as_ref().expect("just made").value;
            // The chain from the first effect whose parameters changed since the last paint
            // of this film: the canvas before it was kept then.
            let base = PrefixKey { film: film_gen, layout: key.layout, pre: pre_gen, palette: painter.key.palette };
            let keys = painter.value.keys();
            let mut prefix = lane.paint_prefix.take().filter(|e| keep && e.key == base);
            let agree = prefix.as_ref().map(|e| e.value.keys.iter().zip(keys).take_while(|(a, b)| a == b).count());
            let resume = match (&prefix, agree) {
                (Some(e), Some(n)) => e.value.snapshot.as_ref().filter(|(done, _)| *done <= n),
                _ => None,
            };
            let keep_at = agree.filter(|&n| n > 0 && n < keys.len());
            // An opaque canvas resumed after every effect that reads the film's hits, with the
            // regions held, reads nothing of the film: its colour starts as the kept canvas,
            // and the moved and refined pixels need not be swapped in (nor out).
            let opaque = !params.paint.transparent;
            let film_unread = keep
                && opaque
                && resume.is_some_and(|(done, _)| *done > 0 && !painter.value.reads_hits_from(*done))
                && inputs.has_regions();
            let mut paint = |film: &mut Film| {
                if !keep {
                    // A one-off render paints the film in place (no second colour buffer:
                    // tests/memory_bound.rs); the painted colour is then the film's own.
                    let r = timings.time(Stage::Paint.name(), || painter.value.apply(film, facets, lighting.as_ref()));
                    return r.map(|()| (Vec::new(), None));
                }
                // (Opaque: the canvas is the colour itself, so the kept one is copied once.)
                let (mut colour, resume) = match resume {
                    Some((done, px)) if opaque => (px.clone(), Some(Resume { done: *done, px: None })),
                    r => (film.color.clone(), r.map(|(done, px)| Resume { done: *done, px: Some(px) })),
                };
                std::mem::swap(&mut film.color, &mut colour);
                let r = timings.time(Stage::Paint.name(), || {
                    painter.value.apply_from(film, facets, lighting.as_ref(), inputs, resume, keep_at)
                });
                std::mem::swap(&mut film.color, &mut colour);
                r.map(|kept| (colour, kept.map(|px| (keep_at.unwrap_or(0), px))))
            };
            let painted = if film_unread {
                paint(film)
            } else {
                with_film(film, Reads::ColourAndHits, delta.as_deref_mut(), aa.as_deref_mut(), None, paint)
            };
            let (painted, kept) = match painted {
                Ok(p) => p,
                Err(e) => {
                    lane.paint_prefix = prefix;
                    return Err(e);
                }
            };
            if keep {
                // The new snapshot, else the old one if the new chain still agrees with it.
                let n = agree.unwrap_or(0);
                let old = prefix.and_then(|e| e.value.snapshot).filter(|(done, _)| *done <= n);
                let snapshot = kept.or(old);
                prefix = Some(Entry { key: base, id: next(), value: Prefix { keys: keys.to_vec(), snapshot } });
                lane.paint_prefix = prefix;
            }
            progress.check()?;
            lane.paint = Some(Entry { key, id: next(), value: painted });
        }
        colour_gen = gen_of(&lane.paint);
    }

    let aims: &[FacetAim] = match (&lane.aims, aims_gen) {
        (Some(e), Some(_)) => &e.value,
        _ => &[],
    };
    let key = EncodeKey {
        colour: colour_gen,
        film: film_gen,
        layout: layout_gen,
        aims: aims_gen,
        saliency: sal_gen,
        passes: params.passes.clone(),
        background: params.trace.background,
        transparent: params.paint.transparent,
        neighbourhood: params.aim.neighbourhood_px(),
        scale: params.aim.scale,
    };
    let encoded = if hit(&lane.encoded, &key) {
        reused.push("encode");
        lane.encoded.as_ref().expect("just checked").value.clone()
    } else {
        lane.encoded = None;
        // (Empty: painted in place, the film's colour is the painted one.)
        let colour =
            if plan.paint { lane.paint.as_mut().map(|e| &mut e.value).filter(|c| !c.is_empty()) } else { None };
        // The image alone reads only the painted colour: the moved and refined pixels are
        // swapped in only for passes (or an unpainted image).
        let film_read = params.passes.is_empty() && colour.is_some();
        let (delta, aa) = if film_read { (None, None) } else { (delta, aa) };
        let (image, passes, passes16) =
            with_film(film, Reads::All, delta, aa, colour, |film| encode_stage(film, map, aims, params, timings));
        let encoded = Encoded { image, passes, passes16 };
        if lane.keep {
            lane.encoded = Some(Entry { key, id: next(), value: encoded.clone() });
        }
        encoded
    };
    let out = &lane.layout.as_ref().expect("layout just made").value;
    if let Some(path) = &params.save_facets {
        facets::io::save(path, &out.layout, &out.map)?;
    }
    Ok((encoded, warnings, view.describe_camera(prep), reused, pixels_kept))
}

/// What `Session::set_scene` or `Session::load_scene` did.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SceneUpdate {
    /// Whether the scene differs from the one before (false: every kept output still holds).
    pub changed: bool,
    /// Whether the file was read and parsed (false: its bytes were those loaded before).
    pub reloaded: bool,
    /// Whether the BVH was built again (the placed triangles changed).
    pub bvh_rebuilt: bool,
    /// Meshes in the scene, and how many are new or changed (only those compute saliency).
    pub meshes: usize,
    pub meshes_changed: usize,
}

/// A scene file as last loaded: its bytes, and whether they are all the scene reads.
#[derive(Clone, Debug, PartialEq)]
struct FileStamp {
    path: std::path::PathBuf,
    /// What the file was allowed to reach (a change loads it again).
    options: LoadOptions,
    bytes: u128,
    self_contained: bool,
}

struct SceneEntry {
    prep: Prepared,
    id: Gen,
    /// Everything a render reads of the scene.
    content: u128,
    /// What the BVH is built from: the placed triangles.
    geometry: u128,
    /// Saliency content key per mesh (what changed meshes are counted by).
    meshes: Vec<u128>,
    /// None: the built-in still life or a scene given in memory.
    file: Option<FileStamp>,
    builtin: bool,
}

/// What a session holds, for `cubist serve`'s `stats`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SessionStats {
    /// The scene's source (a path, `<default scene>` or `<memory>`), triangles and meshes.
    pub scene: Option<String>,
    pub triangles: usize,
    pub meshes: usize,
    /// Meshes whose saliency is kept.
    pub saliency_meshes: usize,
    /// Kept outputs per image size, most recent first.
    pub lanes: Vec<LaneStats>,
    /// Bytes the kept outputs use, and the budget.
    pub bytes: u64,
    pub budget: u64,
}

#[derive(Clone, Debug, Serialize)]
pub struct LaneStats {
    pub width: u32,
    pub height: u32,
    pub bytes: u64,
    /// The steps whose output is kept.
    pub outputs: Vec<&'static str>,
}

/// A long-lived renderer: one scene at a time, and the outputs of its latest renders.
///
/// ```no_run
/// # use cubist::{Settings, pipeline::Session, progress::Progress, scene::Scene};
/// let mut session = Session::new();
/// session.set_scene(Scene::default_scene());
/// let first = session.render(&Settings::default(), &Progress::silent()).unwrap();
/// // Another border width: only the paint stage (and encoding) run again.
/// let s = Settings { border_width: 2.0, ..Settings::default() };
/// let second = session.render(&s, &Progress::silent()).unwrap();
/// assert!(second.reused.contains(&"pre-render"));
/// // Another pose of the same meshes: the BVH is rebuilt, mesh saliency is kept.
/// # let posed = Scene::default_scene();
/// session.set_scene(posed);
/// ```
pub struct Session {
    scene: Option<SceneEntry>,
    /// Most recent first.
    lanes: VecDeque<Lane>,
    gens: Gen,
    budget: u64,
}

impl Default for Session {
    fn default() -> Self {
        Session::new()
    }
}

impl Session {
    /// An empty session (no scene yet), with the default memory budget.
    pub fn new() -> Session {
        Session { scene: None, lanes: VecDeque::new(), gens: 0, budget: DEFAULT_BUDGET }
    }

    /// Sets how many bytes kept outputs may use (the current image size's are always kept).
    pub fn with_budget(mut self, bytes: u64) -> Session {
        self.budget = bytes;
        self
    }

    /// Loads `path` (the built-in still life when None), unless it is the file loaded last
    /// with the same bytes (and reads no other file), then `set_scene`. On an error the
    /// previous scene and outputs stay.
    pub fn load_scene(&mut self, path: Option<&Path>) -> Result<SceneUpdate> {
        self.load_scene_with(path, LoadOptions::default())
    }

    /// `load_scene` with what the file may reach besides itself (`params::load_options`).
    pub fn load_scene_with(&mut self, path: Option<&Path>, options: LoadOptions) -> Result<SceneUpdate> {
        let Some(path) = path else {
            if self.scene.as_ref().is_some_and(|s| s.builtin) {
                return Ok(self.unchanged(false));
            }
            let mut update = self.set_scene(Scene::default_scene());
            update.reloaded = true;
            if let Some(s) = self.scene.as_mut() {
                s.builtin = true;
            }
            return Ok(update);
        };
        let stamp = stamp(path, options);
        if let (Some(s), Some(st)) = (&self.scene, &stamp)
            && st.self_contained
            && s.file.as_ref() == Some(st)
        {
            return Ok(self.unchanged(false));
        }
        let scene = Scene::load_with(path, options)?;
        let mut update = self.set_scene(scene);
        update.reloaded = true;
        if let Some(s) = self.scene.as_mut() {
            s.file = stamp;
        }
        Ok(update)
    }

    /// Makes `scene` the session's scene. Nothing changes when its content is the current
    /// scene's. Otherwise the scene is flattened again; the BVH is kept while the placed
    /// triangles are bit for bit the same (a change of lights, materials or camera) and built
    /// again otherwise (the whole BVH: per-mesh rebuilds wait for the two-level BVH); each
    /// mesh's saliency is kept by content, so only new or edited meshes compute theirs.
    pub fn set_scene(&mut self, scene: Scene) -> SceneUpdate {
        let (content, geometry, meshes) = fingerprints(&scene);
        if let Some(s) = &mut self.scene
            && s.content == content
        {
            s.file = None;
            s.builtin = false;
            return self.unchanged(false);
        }
        let t = Instant::now();
        let world = World::new(&scene);
        let old = self.scene.take();
        let changed = meshes.iter().filter(|k| !old.as_ref().is_some_and(|o| o.meshes.contains(k))).count();
        let (accel, memo, rebuilt) = match old {
            Some(o) if o.geometry == geometry => (o.prep.accel, o.prep.saliency, false),
            Some(o) => (Accel::new(&world), o.prep.saliency, true),
            None => (Accel::new(&world), Default::default(), true),
        };
        // Per-mesh saliency of meshes no longer in the scene is dropped (bounded memory).
        let methods = [SaliencyMethod::Auto, SaliencyMethod::Exact, SaliencyMethod::Clustered];
        let keep: std::collections::HashSet<u128> =
            scene.meshes.iter().flat_map(|m| methods.map(|k| saliency::content_key(m, k))).collect();
        memo.retain(|k| keep.contains(&k));
        let prep = Prepared { scene, world, accel, build_time: t.elapsed(), saliency: memo };
        self.gens += 1;
        let count = meshes.len();
        self.scene = Some(SceneEntry { prep, id: self.gens, content, geometry, meshes, file: None, builtin: false });
        // Every kept output read the old scene.
        self.lanes.clear();
        SceneUpdate { changed: true, reloaded: false, bvh_rebuilt: rebuilt, meshes: count, meshes_changed: changed }
    }

    fn unchanged(&self, reloaded: bool) -> SceneUpdate {
        let meshes = self.scene.as_ref().map_or(0, |s| s.meshes.len());
        SceneUpdate { changed: false, reloaded, bvh_rebuilt: false, meshes, meshes_changed: 0 }
    }

    /// The scene as prepared (None before the first `set_scene`/`load_scene`).
    pub fn prepared(&self) -> Option<&Prepared> {
        self.scene.as_ref().map(|s| &s.prep)
    }

    /// Renders `settings` through every stage, re-running only those whose inputs differ from
    /// what this session kept for the image size; the result is the picture `pipeline::render`
    /// gives for the same scene and settings, bit for bit. A cancelled render (`progress`'s
    /// flag) returns `Error::Cancelled` and keeps the stages it finished.
    pub fn render(&mut self, settings: &Settings, progress: &Progress) -> Result<Frame> {
        settings.validate()?;
        let params = StageParams::new(settings);
        let scene = self.scene.as_ref().ok_or_else(|| Error::Internal("no scene to render: set one first".into()))?;
        let (w, h) = (params.trace.width, params.trace.height);
        let at = self.lanes.iter().position(|l| l.size == (w, h));
        let lane = match at {
            Some(i) => self.lanes.remove(i).expect("found"),
            None => Lane::new(w, h, true),
        };
        self.lanes.push_front(lane);
        self.lanes.truncate(LANES);
        let out = run(&scene.prep, scene.id, &mut self.lanes[0], &mut self.gens, &params, progress, None);
        // Within the budget: the oldest sizes go first; the one in use stays.
        while self.lanes.len() > 1 && self.lanes.iter().map(Lane::bytes).sum::<u64>() > self.budget {
            self.lanes.pop_back();
        }
        out
    }

    /// The facet layout, facet map and aims kept for an image size (the latest render's at
    /// that size), e.g. for facets that follow motion from frame to frame.
    pub fn facets(&self, width: u32, height: u32) -> Option<(&FacetLayout, &FacetMap, &[FacetAim])> {
        let lane = self.lanes.iter().find(|l| l.size == (width, height))?;
        let layout = &lane.layout.as_ref()?.value;
        let aims = lane.aims.as_ref().map_or(&[][..], |e| &e.value[..]);
        Some((&layout.layout, &layout.map, aims))
    }

    /// Drops every kept stage output (the scene, its BVH and mesh saliency stay).
    pub fn clear(&mut self) {
        self.lanes.clear();
    }

    /// Drops everything, the scene too.
    pub fn reset(&mut self) {
        self.lanes.clear();
        self.scene = None;
    }

    pub fn stats(&self) -> SessionStats {
        let lanes: Vec<LaneStats> = self
            .lanes
            .iter()
            .map(|l| LaneStats { width: l.size.0, height: l.size.1, bytes: l.bytes(), outputs: l.held() })
            .collect();
        let scene = self.scene.as_ref();
        SessionStats {
            scene: scene.map(|s| match (&s.file, s.builtin) {
                (Some(f), _) => f.path.display().to_string(),
                (None, true) => "<default scene>".into(),
                (None, false) => "<memory>".into(),
            }),
            triangles: scene.map_or(0, |s| s.prep.world.triangle_count()),
            meshes: scene.map_or(0, |s| s.prep.scene.meshes.len()),
            saliency_meshes: scene.map_or(0, |s| s.prep.saliency.len()),
            bytes: lanes.iter().map(|l| l.bytes).sum(),
            lanes,
            budget: self.budget,
        }
    }
}

/// The bytes of a scene file and whether they are all the scene reads: a .glb whose buffers
/// and images are in the file (or `data:` URIs). Other files (.gltf with .bin and textures
/// beside it) are always read again. None when the file cannot be read (loading says why).
fn stamp(path: &Path, options: LoadOptions) -> Option<FileStamp> {
    let mut head = Vec::new();
    let hasher = hash_file(path, |chunk| {
        if head.len() < 20 {
            head.extend_from_slice(&chunk[..chunk.len().min(20 - head.len())]);
        }
    })?;
    let self_contained = glb_json(path, &head).is_some_and(|json| {
        let external = |key: &str| {
            json.get(key).and_then(|v| v.as_array()).is_some_and(|items| {
                items.iter().any(|i| i.get("uri").and_then(|u| u.as_str()).is_some_and(|u| !u.starts_with("data:")))
            })
        };
        !external("buffers") && !external("images")
    });
    Some(FileStamp { path: path.to_path_buf(), options, bytes: hasher.digest128(), self_contained })
}

/// The JSON chunk of a binary glTF (`head`: its first 20 bytes), if it is one.
fn glb_json(path: &Path, head: &[u8]) -> Option<serde_json::Value> {
    use std::io::{Read, Seek, SeekFrom};
    if head.len() < 20 || &head[..4] != b"glTF" || &head[16..20] != b"JSON" {
        return None;
    }
    let len = u32::from_le_bytes(head[12..16].try_into().ok()?) as u64;
    let (mut f, size) = crate::util::files::open_regular(path, u64::MAX).ok()?;
    if len > size {
        return None;
    }
    f.seek(SeekFrom::Start(20)).ok()?;
    let mut json = Vec::new();
    f.take(len).read_to_end(&mut json).ok()?;
    serde_json::from_slice(&json).ok()
}

/// The scene's content keys: everything a render reads of it; what the BVH is built from (each
/// object's mesh geometry and placement); and each mesh's saliency content key.
fn fingerprints(scene: &Scene) -> (u128, u128, Vec<u128>) {
    use bytemuck::cast_slice;
    let meshes: Vec<u128> = scene.meshes.iter().map(|m| saliency::content_key(m, SaliencyMethod::Auto)).collect();
    let mut geometry = Xxh3::new();
    for o in &scene.objects {
        geometry.update(&meshes.get(o.mesh).copied().unwrap_or(0).to_le_bytes());
        geometry.update(cast_slice(&o.transform.to_cols_array()));
    }
    let geometry = geometry.digest128();

    let mut h = Xxh3::new();
    let text = |h: &mut Xxh3, s: &str| {
        h.update(&(s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
    };
    h.update(&geometry.to_le_bytes());
    for m in &scene.meshes {
        text(&mut h, &m.name);
        h.update(cast_slice(&m.positions));
        h.update(cast_slice(&m.normals));
        h.update(&[m.uvs.is_some() as u8, m.colors.is_some() as u8]);
        if let Some(uv) = &m.uvs {
            h.update(cast_slice(uv));
        }
        if let Some(c) = &m.colors {
            h.update(cast_slice(c));
        }
        h.update(cast_slice(&m.triangles));
        h.update(&m.material.map_or(u64::MAX, |i| i as u64).to_le_bytes());
    }
    for o in &scene.objects {
        text(&mut h, &o.name);
        h.update(&(o.mesh as u64).to_le_bytes());
    }
    for m in &scene.materials {
        text(&mut h, &format!("{m:?}"));
    }
    for t in &scene.textures {
        text(&mut h, &format!("{} {} {:?} {:?} {:?}", t.width, t.height, t.wrap_s, t.wrap_t, t.filter));
        h.update(cast_slice(&t.pixels));
    }
    // Lights, camera and warnings: small; their Debug forms print every float exactly.
    text(&mut h, &format!("{:?} {:?} {:?}", scene.lights, scene.camera, scene.warnings));
    (h.digest128(), geometry, meshes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_delta_swapped_twice_leaves_the_film_as_it_was() {
        let mut film = Film::new(4, 3, 2);
        for (i, c) in film.color.iter_mut().enumerate() {
            *c = Vec4::splat(i as f32);
        }
        let before = film.clone();
        let mut delta = Delta::gather(&film, vec![1, 5, 11]);
        for (k, c) in delta.color.iter_mut().enumerate() {
            *c = Vec4::splat(100.0 + k as f32);
        }
        delta.hits[1].tri = 7;
        delta.samples[5].tri = 9;
        delta.swap(&mut film);
        assert_eq!(film.color[5], Vec4::splat(101.0));
        assert_eq!(film.hits[5].tri, 7);
        assert_eq!(film.samples[11 * 2 + 1].tri, 9);
        assert_eq!(film.color[0], before.color[0]);
        delta.swap(&mut film);
        assert_eq!(film.color, before.color);
        assert_eq!(film.hits, before.hits);
        assert_eq!(film.samples, before.samples);
    }

    #[test]
    fn fingerprints_follow_content_not_identity() {
        let a = Scene::default_scene();
        let (c, g, m) = fingerprints(&a);
        assert_eq!((c, g, m.clone()), fingerprints(&a.clone()));
        // A material changed: the content changes, not the geometry.
        let mut lit = a.clone();
        lit.materials[0].roughness *= 0.5;
        let (c2, g2, m2) = fingerprints(&lit);
        assert_ne!(c, c2);
        assert_eq!((g, &m), (g2, &m2));
        // An object moved: the geometry changes, no mesh does.
        let mut moved = a.clone();
        moved.objects[0].transform.w_axis.x += 0.5;
        let (_, g3, m3) = fingerprints(&moved);
        assert_ne!(g, g3);
        assert_eq!(m, m3);
        // A vertex moved: that one mesh changes.
        let mut edited = a.clone();
        edited.meshes[1].positions[0].y += 0.01;
        let (_, _, m4) = fingerprints(&edited);
        assert_eq!(m.iter().zip(&m4).filter(|(x, y)| x != y).count(), 1);
    }

    #[test]
    fn every_faceting_method_says_whether_it_reads_the_picture() {
        let base = crate::pipeline::params::facets(&Settings::default());
        assert!(reads_picture(&FacetParams { method: FacetMethod::Segment, ..base.clone() }));
        assert!(!reads_picture(&FacetParams { method: FacetMethod::Voronoi, ..base.clone() }));
        let loaded = FacetParams { layout_file: Some("l.json".into()), method: FacetMethod::Segment, ..base };
        assert!(!reads_picture(&loaded));
    }
}
