//! The render pipeline of SPEC Fig. 4.1 as explicit stages, each run only when the settings
//! need it. `params` turns the validated settings into each stage's own parameters; every
//! stage below is a function of plain values to plain values:
//!
//! | stage | inputs | output |
//! |---|---|---|
//! | `prerender` | scene (`Prepared`), `FramingParams`, `TraceParams` | `PreRender`: film (colour, hits, samples), camera, lights |
//! | `saliency_stage` | scene, pre-render film, `SaliencyParams` | per-pixel saliency map |
//! | `layout_stage` | pre-render film (+ map), `FacetParams` | `FacetLayout`, its `FacetMap` |
//! | `aims_stage` | camera, facet map, saliency map and coverage, `AimParams` | one `FacetAim` per facet |
//! | `retrace_stage` | camera, facet map, aims, `TraceParams` | film with moved facets traced again |
//! | `antialias_stage` | camera, facet map, aims, film, `TraceParams` | film colour with `spp` samples where needed |
//! | `paint_stage` | film, facet map, lights, `PaintParams` | film colour painted |
//! | `encode_stage` | film, facets, aims, passes | image and pass images |
//!
//! `Session` (`session.rs`) keeps these outputs between renders, each keyed by what its stage
//! reads, for `cubist serve` and animation frames.
//!
//! A stage's output depends on nothing but its inputs, so a long-lived process (a render
//! server, the frames of an animation) keeps any stage's output and skips the stage while
//! its inputs are unchanged: `session` runs the stages in order, each only when its key
//! (exactly what it reads) changed, and `render` is that same sequence with nothing kept.
//!
//! The other products of the pre-render: `saliency_map` (`cubist saliency`),
//! `inspect_facets` (`cubist facets`), `evaluate` (`cubist faces`) and `look` (`cubist look`).

mod faces;
mod follow_frame;
pub mod frames;
mod inspect;
mod look;
pub mod params;
mod prepared;
mod prerender;
mod saliency_map;
mod session;
mod stage;

use glam::DVec2;
use image::RgbaImage;

use crate::camera::CameraRay;
use crate::error::Result;
use crate::facets::{self, FacetLayout, FacetMap, FacetParams};
use crate::film::Film;
use crate::imprecision::cues::CentreHits;
use crate::imprecision::{self, AimContext, AimParams, FacetAim};
use crate::output::passes::{facet_ids_pass, facets_pass, geometry_pass};
use crate::output::{Gray16, Pass, encode};
use crate::progress::Progress;
use crate::saliency::{MeshSaliency, SaliencyParams};
use crate::settings::Settings;
use crate::trace::{KnownHits, TraceParams, Tracer};

pub use faces::{evaluate, visible_faces};
pub use follow_frame::{follows_saved_key, render_followed_frame};
pub use frames::{FrameOutput, FramesParams, FramesSummary, render_frames};
pub use inspect::{Inspection, faceting_input, inspect_facets};
pub use look::{Look, look};
pub use params::StageParams;
pub use prepared::Prepared;
pub use prerender::{PreRender, Shading, View, prerender};
pub use saliency_map::{SaliencyRender, saliency_map};
pub use session::{DEFAULT_BUDGET, Frame, LANES, LaneStats, PixelsKept, SceneUpdate, Session, SessionStats};
pub use stage::{MESH_SALIENCY_OVERLAPPED, Plan, Stage, Timings, process_cpu};

/// What a render produces.
pub struct Rendered {
    pub film: Film,
    pub image: RgbaImage,
    pub passes: Vec<(Pass, RgbaImage)>,
    /// Passes stored as 16-bit grey (facet ids), written with `output::write_png16`.
    pub passes16: Vec<(Pass, Gray16)>,
    /// The facet id of every pixel (a single facet when unfaceted); painterly effects read it.
    pub facets: FacetMap,
    /// The facet layout `facets` was rasterised from (what `save_facets` saves).
    pub layout: FacetLayout,
    /// Each facet's centres and re-aim, when the imprecision stage ran (else empty).
    pub aims: Vec<FacetAim>,
    pub timings: Timings,
    pub warnings: Vec<String>,
    /// One line saying which camera was used and where its focal centre is.
    pub camera: String,
}

/// Renders `settings` through the whole pipeline.
pub fn render(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<Rendered> {
    render_hooked(prep, settings, progress, None)
}

/// `render`, calling `after_saliency` on the film once the pre-render and saliency stages are
/// done and before faceting: tests and evaluations use it to supply a known saliency map.
/// The stages run in `session::run`, the sequence a `Session` runs too, here with nothing kept.
pub fn render_with(
    prep: &Prepared,
    settings: &Settings,
    progress: &Progress,
    after_saliency: &dyn Fn(&Prepared, &mut Film),
) -> Result<Rendered> {
    render_hooked(prep, settings, progress, Some(after_saliency))
}

/// `render_with`, the hook optional: without one, a render whose stages before the re-trace
/// read no colour shades only the pixels the re-trace keeps (`Shading::Deferred`); a hook
/// sees the film fully shaded.
fn render_hooked(
    prep: &Prepared,
    settings: &Settings,
    progress: &Progress,
    after_saliency: Option<&session::AfterSaliency<'_>>,
) -> Result<Rendered> {
    settings.validate()?;
    let params = StageParams::new(settings);
    let mut lane = session::Lane::new(params.trace.width, params.trace.height, false);
    let frame = session::run(prep, 0, &mut lane, &mut 0, &params, progress, after_saliency)?;
    let (film, facets, layout, aims) = lane.into_products()?;
    Ok(Rendered {
        film,
        image: frame.image,
        passes: frame.passes,
        passes16: frame.passes16,
        facets,
        layout,
        aims,
        timings: frame.timings,
        warnings: frame.warnings,
        camera: frame.camera,
    })
}

/// Work that would take hours, refused before anything runs (issue 18): the Segment
/// faceting's eigenvectors. (The lights' work depends on the scene: `prerender` checks it.)
pub fn check_work(params: &StageParams) -> Result<()> {
    if params.facets.method == facets::FacetMethod::Segment && params.facets.layout_file.is_none() {
        facets::segment::check_work(params.facets.width, params.facets.height, &params.facets.segment)?;
    }
    Ok(())
}

/// Mesh saliency (SPEC "Mesh saliency") of the meshes the pre-render hit, and the saliency
/// map read off the same samples (no second trace).
pub fn saliency_stage(
    prep: &Prepared,
    film: &Film,
    params: &SaliencyParams,
    progress: &Progress,
    timings: &mut Timings,
) -> Result<(MeshSaliency, Vec<f32>)> {
    progress.begin(Stage::Saliency.name(), 1);
    let out = timings.time(Stage::Saliency.name(), || {
        crate::saliency::for_film(&prep.scene, &prep.world, &prep.saliency, film, params).map(|sal| {
            let map = crate::saliency::saliency_map(&prep.world, &sal, film);
            (sal, map)
        })
    })?;
    progress.finish();
    Ok(out)
}

/// Faceting (SPEC "Faceting"): the layout computed from the pre-render, or loaded so every
/// frame of an animation shares it, and rasterised at this size. Unfaceted: one facet.
pub fn layout_stage(
    params: &FacetParams,
    film: &Film,
    progress: &Progress,
    timings: &mut Timings,
    warnings: &mut Vec<String>,
) -> Result<(FacetLayout, FacetMap)> {
    let (width, height) = (params.width, params.height);
    let (layout, map) = if params.faceted() {
        progress.begin(Stage::Faceting.name(), 1);
        timings.time(Stage::Faceting.name(), || -> Result<(FacetLayout, FacetMap)> {
            let layout = facets::layout_for(params, film)?;
            let map = layout.rasterize(width, height);
            Ok((layout, map))
        })?
    } else {
        let layout = FacetLayout::single();
        let map = layout.rasterize(width, height);
        (layout, map)
    };
    if let (Some(path), Some(base)) = (&params.layout_file, &layout.base) {
        let (a, b) = (width as f64 / height as f64, base.width as f64 / base.height as f64);
        if (a / b - 1.0).abs() > 0.01 {
            warnings.push(format!(
                "facet layout {} is {}x{}, stretched to this {width}x{height} image",
                path.display(),
                base.width,
                base.height
            ));
        }
    }
    Ok((layout, map))
}

/// What re-aiming needs of the pre-render's camera and the scene.
fn aim_context<'a>(prep: &'a Prepared, view: &'a View, trace: &TraceParams) -> AimContext<'a> {
    let clip_radius = (prep.world.radius as f64).max(1e-9) * 1.001;
    AimContext {
        camera: view.framed.camera.as_ref(),
        accel: &prep.accel,
        width: trace.width,
        height: trace.height,
        clip_radius,
    }
}

/// Each facet's centres, the point it is aimed at and its new rays (`imprecision`).
/// `mesh`: the scene whose pre-render `film` is and how its mesh saliency was computed, to keep
/// its most salient vertices in view (None: not checked, e.g. a posed animation frame).
pub fn aims_stage(
    ctx: &AimContext,
    map: &FacetMap,
    film: &Film,
    params: &AimParams,
    mesh: Option<(&Prepared, &SaliencyParams)>,
    progress: &Progress,
    timings: &mut Timings,
) -> Vec<FacetAim> {
    aims_stage_traced(ctx, map, film, params, mesh, progress, timings).0
}

/// `aims_stage`, also returning the centre hits the cue check traced through the aims kept
/// (`imprecision::cues::CentreHits`), which `retrace_stage` takes instead of tracing again.
pub fn aims_stage_traced(
    ctx: &AimContext,
    map: &FacetMap,
    film: &Film,
    params: &AimParams,
    mesh: Option<(&Prepared, &SaliencyParams)>,
    progress: &Progress,
    timings: &mut Timings,
) -> (Vec<FacetAim>, Option<CentreHits>) {
    progress.begin(Stage::Imprecision.name(), 1);
    timings.time(Stage::Imprecision.name(), || {
        // Every facet's pixels, made once for the centres, the coverage and the cue checks.
        let by_facet = map.facet_pixels();
        let mut aims = imprecision::aim_facets_with(ctx, map, &by_facet, film.saliency.as_deref(), params);
        // What a facet may show (issue 13): backdrop kept, shifts within the facet's width,
        // the most salient vertices kept in view. The mesh saliency is the memo's since the
        // saliency stage (a failure there was reported there).
        let saliency = mesh
            .filter(|_| params.reads_saliency() && film.saliency.is_some())
            .and_then(|(prep, p)| crate::saliency::for_film(&prep.scene, &prep.world, &prep.saliency, film, p).ok());
        let cues = mesh
            .zip(saliency.as_ref())
            .and_then(|((prep, _), s)| imprecision::cues::CueVertices::new(&prep.scene, &prep.world, &s.per_mesh));
        let hits = imprecision::backdrop::apply(&mut aims, ctx, map, &by_facet, film, cues.as_ref(), params);
        (aims, hits)
    })
}

/// The pixels of the facets whose rays moved (what the re-trace traces again).
pub fn moved_pixels(map: &FacetMap, aims: &[FacetAim]) -> Vec<u32> {
    use rayon::prelude::*;
    // In parallel, in pixel order (rayon's collect keeps it).
    (0..map.ids.len() as u32).into_par_iter().filter(|&i| aims[map.ids[i as usize] as usize].moved()).collect()
}

/// Each pixel's ray through its facet: the camera's, re-aimed where the facet's aim moved
/// (`aims` empty: the camera's everywhere). What the re-trace, the anti-aliasing and every
/// animation frame trace.
pub fn facet_rays<'a>(
    ctx: &'a AimContext<'a>,
    map: &'a FacetMap,
    aims: &'a [FacetAim],
) -> impl Fn(usize, DVec2) -> CameraRay + Sync + 'a {
    // The pixel centres' rays tabulated where the camera can (`Camera::centre_rays`): the
    // re-trace traces them; anti-aliasing's jittered points take `ray`.
    let camera = ctx.camera.centre_rays(ctx.width, ctx.height);
    move |i, p| {
        let ray = camera(i, p);
        match aims.get(map.ids[i] as usize) {
            Some(aim) if aim.moved() => aim.apply(ray, ctx.pixel_pos(p), ctx.clip_radius),
            _ => ray,
        }
    }
}

/// After a `Shading::Deferred` pre-render: shades the pixels the re-trace does not trace
/// again (those not in `moved`, `moved_pixels`) as the lit pre-render would have, from the
/// hits the film holds (`Tracer::shade_traced`; timed as `shading`, progress counted in the
/// re-trace).
#[allow(clippy::too_many_arguments)]
pub fn shade_stage(
    prep: &Prepared,
    view: &View,
    ctx: &AimContext,
    trace: &TraceParams,
    moved: &[u32],
    film: &mut Film,
    progress: &Progress,
    timings: &mut Timings,
) {
    use rayon::prelude::*;
    let n = film.pixel_count();
    // The complement of `moved` (ascending), in parallel, in pixel order.
    let mut is_moved = vec![false; n];
    for &i in moved {
        is_moved[i as usize] = true;
    }
    let kept: Vec<u32> = (0..n as u32).into_par_iter().filter(|&i| !is_moved[i as usize]).collect();
    drop(is_moved);
    progress.begin(Stage::ReTrace.name(), kept.len() as u64);
    let tracer = view.tracer(prep, trace);
    let rays = ctx.camera.centre_rays(film.width, film.height);
    timings.time("shading", || tracer.shade_traced(film, &*rays, &kept, progress));
    progress.finish();
}

/// Traces again the `moved` pixels (`moved_pixels`) with the pre-render's tracer (the same
/// lights, background and samples), overwriting their colour, hits and samples in `film`.
/// `centre`: the cue check's hits of these very centre rays (`aims_stage_traced`), taken
/// instead of tracing them again where they are the hits of `aims`.
#[allow(clippy::too_many_arguments)]
pub fn retrace_stage(
    prep: &Prepared,
    view: &View,
    ctx: &AimContext,
    trace: &TraceParams,
    map: &FacetMap,
    aims: &[FacetAim],
    moved: &[u32],
    centre: Option<&CentreHits>,
    film: &mut Film,
    progress: &Progress,
    timings: &mut Timings,
) {
    if moved.is_empty() {
        return;
    }
    progress.begin(Stage::ReTrace.name(), moved.len() as u64);
    let tracer = view.tracer(prep, trace);
    // The hits hold for the pre-render's scene and camera (`ctx`) at one sample per pixel.
    let centre = centre.filter(|_| std::ptr::eq(tracer.accel, ctx.accel) && film.width == ctx.width);
    let known = centre.map(|c| c.known(map, aims));
    let rays = facet_rays(ctx, map, aims);
    timings.time(Stage::ReTrace.name(), || {
        let known = known.as_ref().map(|k| k as &KnownHits);
        tracer.render_known(film, &rays, Some(moved), Some(&map.ids), known, progress)
    });
    progress.finish();
}

/// Traces `pixels` (all: None) of `film` through their facets' rays (`facet_rays`) with
/// `tracer` (timed as `re-trace`; `progress` counts the pixels). At one sample per pixel,
/// shadow rays are cast sparsely (`Tracer::render`).
#[allow(clippy::too_many_arguments)]
pub fn trace_facets(
    tracer: &Tracer,
    ctx: &AimContext,
    map: &FacetMap,
    aims: &[FacetAim],
    pixels: Option<&[u32]>,
    film: &mut Film,
    progress: &Progress,
    timings: &mut Timings,
) {
    let rays = facet_rays(ctx, map, aims);
    timings.time(Stage::ReTrace.name(), || tracer.render(film, &rays, pixels, Some(&map.ids), progress));
}

/// Anti-aliasing: the pixels that need them (all with `aa_threshold` 0) get `spp` samples each
/// through their facet's rays, the pre-render's and re-trace's single centre samples telling
/// which (`trace::pixels_to_refine`).
#[allow(clippy::too_many_arguments)]
pub fn antialias_stage(
    prep: &Prepared,
    view: &View,
    ctx: &AimContext,
    trace: &TraceParams,
    map: &FacetMap,
    aims: &[FacetAim],
    film: &mut Film,
    progress: &Progress,
    timings: &mut Timings,
) {
    antialias_with(&view.tracer(prep, trace), ctx, trace, map, aims, film, progress, timings);
}

/// serve5 (issue 14): `antialias_stage` for a session, which keeps the refined pixels' colours:
/// each pixel to refine whose colour `reuse(pixel, known)` gives (`trace::antialias_known`:
/// the lights its neighbours agree on) takes it, the others are traced. Returns the refined
/// pixels (ascending), their `known` numbers and colours, and how many were traced; the film's
/// colour is left as it was.
#[allow(clippy::too_many_arguments)]
pub fn antialias_reusing(
    prep: &Prepared,
    view: &View,
    ctx: &AimContext,
    trace: &TraceParams,
    map: &FacetMap,
    aims: &[FacetAim],
    film: &mut Film,
    reuse: &(dyn Fn(u32, u64) -> Option<glam::Vec4> + Sync),
    progress: &Progress,
    timings: &mut Timings,
) -> (Vec<u32>, Vec<u64>, Vec<glam::Vec4>, usize) {
    use rayon::prelude::*;
    let tracer = view.tracer(prep, trace);
    let rays = facet_rays(ctx, map, aims);
    let out = timings.time(Stage::AntiAliasing.name(), || {
        let ids = aa_facets(map, aims);
        let ids: &[u32] = &ids;
        let pixels = crate::trace::pixels_to_refine(film, ids, trace.aa_threshold);
        let known: Vec<u64> =
            pixels.par_iter().map(|&i| crate::trace::antialias_known(film, ids, i as usize)).collect();
        let mut colours: Vec<Option<glam::Vec4>> = pixels.par_iter().zip(&known).map(|(&i, &k)| reuse(i, k)).collect();
        let again: Vec<u32> = pixels.iter().zip(&colours).filter(|(_, c)| c.is_none()).map(|(&i, _)| i).collect();
        progress.begin(Stage::AntiAliasing.name(), again.len() as u64);
        let before: Vec<glam::Vec4> = again.iter().map(|&i| film.color[i as usize]).collect();
        tracer.antialias(film, &rays, &again, ids, trace.spp, progress);
        let mut traced = again.iter().zip(before).map(|(&i, c)| std::mem::replace(&mut film.color[i as usize], c));
        let colours = colours.iter_mut().map(|c| c.take().or_else(|| traced.next()).unwrap_or_default()).collect();
        (pixels, known, colours, again.len())
    });
    progress.finish();
    out
}

/// The facets anti-aliasing compares pixels within: the map's, or one facet where no facet
/// moved (every ray is then the camera's, so facet borders are no edges of the picture and the
/// image is the unfaceted one).
fn aa_facets<'a>(map: &'a FacetMap, aims: &[FacetAim]) -> std::borrow::Cow<'a, [u32]> {
    if aims.iter().any(|a| a.moved()) {
        std::borrow::Cow::Borrowed(&map.ids)
    } else {
        std::borrow::Cow::Owned(vec![0u32; map.ids.len()])
    }
}

/// `antialias_stage` with any tracer (an animation frame's posed scene and lights) and the
/// camera of `ctx`.
#[allow(clippy::too_many_arguments)]
pub fn antialias_with(
    tracer: &Tracer,
    ctx: &AimContext,
    trace: &TraceParams,
    map: &FacetMap,
    aims: &[FacetAim],
    film: &mut Film,
    progress: &Progress,
    timings: &mut Timings,
) {
    let rays = facet_rays(ctx, map, aims);
    timings.time(Stage::AntiAliasing.name(), || {
        let ids = aa_facets(map, aims);
        let ids: &[u32] = &ids;
        let pixels = crate::trace::pixels_to_refine(film, ids, trace.aa_threshold);
        progress.begin(Stage::AntiAliasing.name(), pixels.len() as u64);
        tracer.antialias(film, &rays, &pixels, ids, trace.spp, progress);
    });
    progress.finish();
}

/// The output image and the passes the settings ask for.
#[allow(clippy::type_complexity)]
pub fn encode_stage(
    film: &Film,
    map: &FacetMap,
    aims: &[FacetAim],
    params: &StageParams,
    timings: &mut Timings,
) -> (RgbaImage, Vec<(Pass, RgbaImage)>, Vec<(Pass, Gray16)>) {
    let (background, transparent) = (params.trace.background, params.paint.transparent);
    let image = timings.time("encode", || encode(film, background, transparent));
    let mut passes = Vec::new();
    let mut passes16 = Vec::new();
    for &pass in &params.passes {
        if let Some(img) = geometry_pass(film, pass) {
            passes.push((pass, img));
        }
        match pass {
            Pass::Facets => {
                let shown = if aims.is_empty() {
                    imprecision::centres_only(map, film.saliency.as_deref(), params.aim.neighbourhood_px())
                } else {
                    aims.to_vec()
                };
                passes.push((pass, facets_pass(map, &shown, film.saliency.as_deref(), params.aim.scale)));
            }
            Pass::FacetIds => passes16.push((pass, facet_ids_pass(map))),
            // The final layout (Fig. 4.5 f); `cubist facets --pass segments` also shows each level.
            Pass::Segments => passes.push((pass, facets::segment::inspection::map_image(map))),
            _ => {}
        }
    }
    (image, passes, passes16)
}
