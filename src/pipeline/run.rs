//! The one stage runner: the stages of a render (thesis Fig. 4.1, `stages`) in order, each run
//! only when its key differs from the output its `Lane` keeps (`cache::Run::step`). A one-off
//! render (`pipeline::render`) runs it over an empty lane with `Policy::OneOff`; a `Session`
//! (`cubist serve`) over the lane it keeps for the image size with `Policy::Kept`. So a kept
//! output gives the pixels a fresh render gives (tests/session.rs checks it at every level).
//!
//! | output | keyed by |
//! |---|---|
//! | pre-render | scene, `FramingParams`, `TraceParams` |
//! | saliency map | pre-render, saliency method, part saliency weight |
//! | facet layout and map | `FacetParams`, its files' contents; pre-render and saliency map when the method reads the picture |
//! | aims | layout, pre-render, saliency map when the mode reads it, `AimParams` |
//! | re-trace | aims (kept as the moved pixels only, swapped into the pre-render's film when read) |
//! | anti-aliasing | re-trace (or pre-render), layout, aims (kept as the refined pixels' colours) |
//! | painter | `PaintParams`, the palette painting's contents |
//! | paint | anti-aliasing (or re-trace, or pre-render), layout, painter, lights (pre-render) |
//! | encoded images | paint, layout, aims, saliency map, passes, background, transparency |
//!
//! So a painterly change re-runs paint (and encoding) only; a facet change faceting onwards; a
//! camera or image change the pre-render onwards.

use std::sync::Arc;

use glam::Vec4;
use image::RgbaImage;

use super::cache::{Entry, Gen, Made, Policy, Run, Slot, file_key};
use super::stages::antialias::{self, ColourDelta, Refining};
use super::stages::encode::{self, Encoded};
use super::stages::layout::{self, Layout, PlanesKey};
use super::stages::paint::{self, PainterKey, Painting, Prefix, PrefixKey};
use super::stages::retrace::{Delta, Reads, Retracing, Traced};
use super::stages::{self, PreRender, Shading, View, prerender, saliency};
use super::{Plan, Prepared, Stage, StageParams, Timings};
use crate::error::{Error, Result};
use crate::facets::{self, FacetLayout, FacetMap, FacetMethod};
use crate::film::{Film, PixelHit, SampleHit};
use crate::imprecision::cues::CentreHits;
use crate::imprecision::{self, AimContext, AimMode, FacetAim};
use crate::output::{Gray16, Pass};
use crate::paint::chiaroscuro::ViewAxes;
use crate::paint::{Lighting, PaintInputs, Painter};
use crate::progress::Progress;
use crate::trace::Tracer;

/// The kept outputs of one image size.
pub(super) struct Lane {
    pub(super) size: (u32, u32),
    pre: Slot<prerender::Key, PreRender>,
    saliency: Slot<saliency::Key, Vec<f32>>,
    /// What the planes faceting reads of the pre-render whatever its plane count and detail.
    planes: Slot<PlanesKey, facets::planes::Guides>,
    layout: Slot<layout::Key, Layout>,
    aims: Slot<stages::aims::Key, Vec<FacetAim>>,
    retrace: Slot<Gen, Delta>,
    aa: Slot<antialias::Key, ColourDelta>,
    painter: Slot<PainterKey, Painter>,
    /// The paint inputs (regions, planes, edges) of a film (the re-trace's) and facet map.
    paint_inputs: Slot<(Gen, Option<Gen>), PaintInputs>,
    paint_prefix: Slot<PrefixKey, Prefix>,
    paint: Slot<paint::Key, Vec<Vec4>>,
    encoded: Slot<encode::Key, Encoded>,
}

impl Lane {
    pub(super) fn new(width: u32, height: u32) -> Lane {
        Lane {
            size: (width, height),
            pre: Slot::default(),
            saliency: Slot::default(),
            planes: Slot::default(),
            layout: Slot::default(),
            aims: Slot::default(),
            retrace: Slot::default(),
            aa: Slot::default(),
            painter: Slot::default(),
            paint_inputs: Slot::default(),
            paint_prefix: Slot::default(),
            paint: Slot::default(),
            encoded: Slot::default(),
        }
    }

    /// Bytes held (the buffers; the small structures around them are not counted).
    pub(super) fn bytes(&self) -> u64 {
        let film = |f: &Film| {
            (f.color.len() * size_of::<Vec4>()
                + f.hits.len() * size_of::<PixelHit>()
                + f.occlusion.len()
                + f.samples.len() * size_of::<SampleHit>()
                + f.saliency.as_ref().map_or(0, |s| s.len() * 4)) as u64
        };
        self.pre.get().map_or(0, |p| film(&p.film))
            + self.saliency.get().map_or(0, |s| s.len() as u64 * 4)
            + self.planes.get().map_or(0, |p| p.bytes())
            + self.layout.get().map_or(0, |l| l.map.ids.len() as u64 * 4)
            + self.retrace.get().map_or(0, Delta::bytes)
            + self.aa.get().map_or(0, ColourDelta::bytes)
            + self.paint_inputs.get().map_or(0, PaintInputs::bytes)
            + self.paint_prefix.get().map_or(0, Prefix::bytes)
            + self.paint.get().map_or(0, |c| (c.len() * size_of::<Vec4>()) as u64)
            + self.encoded.get().map_or(0, Encoded::bytes)
    }

    /// The outputs held, by stage name.
    pub(super) fn held(&self) -> Vec<&'static str> {
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
            ("paint prefix", self.paint_prefix.get().is_some_and(|p| p.snapshot.is_some())),
            (Stage::Paint.name(), self.paint.is_some()),
            ("encode", self.encoded.is_some()),
        ];
        slots.into_iter().filter(|(_, held)| *held).map(|(name, _)| name).collect()
    }

    /// The facet layout, facet map and aims held.
    pub(super) fn facets(&self) -> Option<(&FacetLayout, &FacetMap, &[FacetAim])> {
        let layout = self.layout.get()?;
        let aims = self.aims.get().map_or(&[][..], |a| &a[..]);
        Some((&layout.layout, &layout.map, aims))
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
        let Layout { layout, map, .. } = self.layout.take().ok_or_else(missing)?.value;
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

/// A hook on the film once the saliency map is in (`render_with`).
pub(super) type AfterSaliency<'a> = dyn Fn(&Prepared, &mut Film) + 'a;

/// The stages of one render, in order, each run only when its key differs from the output
/// `lane` holds. `scene`: the scene's generation. `after_saliency` (one-off renders only:
/// tests supply a known saliency map with it) sees the film once the saliency map is in.
#[allow(clippy::too_many_arguments)]
pub(super) fn run(
    prep: &Prepared,
    scene: Gen,
    lane: &mut Lane,
    gens: &mut Gen,
    params: &StageParams,
    policy: Policy,
    progress: &Progress,
    after_saliency: Option<&AfterSaliency<'_>>,
) -> Result<Frame> {
    layout::check_work(&params.facets)?;
    let plan = Plan::new(params);
    let mut run = Run::new(policy, gens, progress);

    // The painter first, so a bad palette image fails before the long part.
    let key = PainterKey { params: params.paint.clone(), palette: file_key(params.paint.palette.image.as_deref()) };
    run.step(&mut lane.painter, key, None, |run, _| {
        run.timings.time("paint setup", || Painter::new(&params.paint)).map(Made::New)
    })?;
    prerender_step(&mut run, lane, prep, scene, params, &plan, after_saliency.is_some())?;
    let pre_gen = lane.pre.id();
    let sal_key = saliency::Key { pre: pre_gen, method: params.saliency.method, parts: params.saliency.parts };
    if plan.saliency {
        let film = &lane.pre.made().film;
        run.step(&mut lane.saliency, sal_key, Some(Stage::Saliency.name()), |run, old| {
            drop(old);
            let (_, map) = stages::saliency_stage(prep, film, &params.saliency, run.progress, &mut run.timings)?;
            Ok(Made::New(map))
        })?;
    }

    let mut pre = lane.pre.take().expect("pre-render just made");
    // The saliency map is lent to the film while the later stages read it.
    let mut sal = if plan.saliency { lane.saliency.take() } else { None };
    pre.value.film.saliency = sal.as_mut().map(|e| std::mem::take(&mut e.value));
    if let Some(hook) = after_saliency {
        hook(prep, &mut pre.value.film);
        if sal.is_none() && pre.value.film.saliency.is_some() {
            sal = Some(Entry { key: sal_key, id: run.new_gen(), value: Vec::new() });
        }
    }
    let sal_gen = sal.as_ref().map(|e| e.id);
    let result = later_stages(&mut run, prep, lane, &mut pre, sal_gen, params, &plan);
    // Back in the lane, whatever happened (a cancel keeps what was done).
    if let Some(e) = sal.as_mut() {
        e.value = pre.value.film.saliency.take().unwrap_or_default();
    }
    pre.value.film.saliency = None;
    if let Some(e) = sal {
        lane.saliency.put(e);
    }
    lane.pre.put(pre);
    let (encoded, warnings, camera, pixels_kept) = result?;
    Ok(Frame {
        image: encoded.image,
        passes: encoded.passes,
        passes16: encoded.passes16,
        timings: run.timings,
        warnings,
        camera,
        reused: run.reused,
        pixels_kept,
    })
}

/// The pre-render, or the one kept. A new one makes everything traced before stale: freed
/// before tracing, for a lower peak. Mesh saliency reads only the meshes: it runs beside
/// framing and the pre-render.
fn prerender_step(
    run: &mut Run,
    lane: &mut Lane,
    prep: &Prepared,
    scene: Gen,
    params: &StageParams,
    plan: &Plan,
    hooked: bool,
) -> Result<()> {
    let key = prerender::Key { scene, framing: params.framing.clone(), trace: params.trace.clone() };
    if !lane.pre.hit(&key) {
        lane.pre.clear();
        lane.planes.clear();
        lane.retrace.clear();
        lane.aa.clear();
        lane.paint_inputs.clear();
        lane.paint_prefix.clear();
        lane.paint.clear();
        lane.encoded.clear();
    }
    // A one-off render whose stages before the re-trace read no colour shades only the
    // pixels the re-trace keeps, after the aims (`shade_stage`).
    let deferred = run.policy == Policy::OneOff
        && !hooked
        && plan.imprecision
        && !(layout::reads_picture(&params.facets) && params.facets.method == FacetMethod::Segment);
    let shading = if deferred { Shading::Deferred } else { Shading::Lit };
    run.step(&mut lane.pre, key, Some(Stage::PreRender.name()), |run, _| {
        let (progress, timings) = (run.progress, &mut run.timings);
        if !plan.saliency {
            return prerender(prep, &params.framing, &params.trace, shading, progress, timings).map(Made::New);
        }
        // (Timed on its own, by wall clock; the pre-render's CPU figures then include it.)
        let (pre, mesh_time) = rayon::join(
            || prerender(prep, &params.framing, &params.trace, shading, progress, timings),
            || {
                let t = std::time::Instant::now();
                crate::saliency::precompute(&prep.scene, &prep.world, &prep.saliency, &params.saliency);
                t.elapsed()
            },
        );
        run.timings.0.push((super::stage::MESH_SALIENCY_OVERLAPPED, mesh_time));
        run.timings.1.push(None);
        pre.map(Made::New)
    })?;
    Ok(())
}

/// The generations of the outputs the later stages read.
#[derive(Clone, Copy)]
struct Gens {
    pre: Gen,
    saliency: Option<Gen>,
    layout: Gen,
    aims: Option<Gen>,
    /// The film as re-traced (the pre-render's without imprecision).
    traced: Gen,
    /// The film as anti-aliased (else as traced).
    film: Gen,
}

/// What the stages from faceting on give: the encoded images, warnings, the camera in words
/// and the pixels kept.
type LaterStages = (Encoded, Vec<String>, String, PixelsKept);

/// `run` from faceting on, with the pre-render (its film holding the saliency map, if any)
/// taken out of the lane.
fn later_stages(
    run: &mut Run,
    prep: &Prepared,
    lane: &mut Lane,
    pre: &mut Entry<prerender::Key, PreRender>,
    saliency: Option<Gen>,
    params: &StageParams,
    plan: &Plan,
) -> Result<LaterStages> {
    let mut pixels_kept = PixelsKept::default();
    let PreRender { film, view, warnings: pre_warnings, unshaded } = &mut pre.value;
    let mut warnings = pre_warnings.clone();
    layout_step(run, &mut lane.layout, &mut lane.planes, film, pre.id, saliency, params, plan)?;
    let layout_out = lane.layout.made();
    warnings.extend(layout_out.warnings.iter().cloned());
    let map = &layout_out.map;
    let pre_gen = pre.id;
    let mut gens =
        Gens { pre: pre_gen, saliency, layout: lane.layout.id(), aims: None, traced: pre_gen, film: pre_gen };

    // Saliency centres count pixels within `neighborhood` of a facet: bounded work, or an error.
    if plan.faceting && params.aim.neighborhood > 0.0 && film.saliency.is_some() {
        imprecision::check_neighbourhood(map, params.aim.neighbourhood_px())?;
    }
    let tracer = view.tracer(prep, &params.trace);
    let ctx = stages::aim_context(prep, view, &params.trace);
    // Spatial imprecision: re-aim and turn facets, re-trace only the pixels of facets whose
    // rays changed; at discontinuity 0 with converging facets and no turn nothing runs.
    if plan.imprecision {
        if params.aim.reads_saliency() && film.saliency.is_none() {
            warnings.push("no saliency map was computed: facets are not re-aimed (imprecision saliency)".into());
        }
        let centre = aims_step(run, &mut lane.aims, prep, &ctx, map, film, &gens, params)?;
        let aims = lane.aims.made();
        gens.aims = Some(lane.aims.id());
        let fresh = Fresh { tracer: &tracer, ctx: &ctx, map, aims, gens };
        retrace_step(run, &mut lane.retrace, &fresh, film, unshaded, centre.as_ref(), &mut pixels_kept)?;
        gens.traced = lane.retrace.id();
    }
    let aims: &[FacetAim] = if plan.imprecision { lane.aims.made() } else { &[] };
    let mut delta = if plan.imprecision { lane.retrace.get_mut() } else { None };
    gens.film = gens.traced;
    if plan.antialiasing {
        let fresh = Fresh { tracer: &tracer, ctx: &ctx, map, aims, gens };
        antialias_step(run, &mut lane.aa, &fresh, &params.trace, film, delta.as_deref_mut(), &mut pixels_kept)?;
        gens.film = lane.aa.id();
    }
    let aa = if plan.antialiasing { lane.aa.get_mut() } else { None };
    let mut picture = Picture { film, delta, aa };

    let colour = if plan.paint {
        let slots = PaintSlots {
            painter: &lane.painter,
            inputs: &mut lane.paint_inputs,
            prefix: &mut lane.paint_prefix,
            paint: &mut lane.paint,
        };
        paint_step(run, slots, prep, view, &mut picture, map, &gens, params, plan)?;
        lane.paint.id()
    } else {
        gens.film
    };
    let key = encode::Key {
        colour,
        film: gens.film,
        layout: gens.layout,
        aims: gens.aims,
        saliency: gens.saliency,
        passes: params.passes.clone(),
        background: params.trace.background,
        transparent: params.paint.transparent,
        neighbourhood: params.aim.neighbourhood_px(),
        scale: params.aim.scale,
    };
    run.step(&mut lane.encoded, key, Some("encode"), |run, _| {
        // (Empty: painted in place, the film's colour is the painted one.)
        let colour = if plan.paint { lane.paint.get_mut().filter(|c| !c.is_empty()) } else { None };
        // The image alone reads only the painted colour: the moved and refined pixels are
        // swapped in only for passes (or an unpainted image).
        let film_read = !(params.passes.is_empty() && colour.is_some());
        Ok(Made::New(picture.with(Reads::All, film_read, colour, |film| {
            stages::encode_stage(film, map, aims, params, &mut run.timings)
        })))
    })?;
    let encoded = match run.policy {
        Policy::Kept => lane.encoded.made().clone(),
        Policy::OneOff => lane.encoded.take().expect("just made").value,
    };
    let out = lane.layout.made();
    if let Some(path) = &params.save_facets {
        facets::io::save(path, &out.layout, &out.map)?;
    }
    Ok((encoded, warnings, view.describe_camera(prep), pixels_kept))
}

/// The facet layout, or the one kept. The planes faceting starts from what it reads of the
/// pre-render whatever its plane count and detail (the density's cues, the outlines), made
/// once per pre-render. The later stages read the facet map alone (a saved layout is written
/// from the new one): a change that gives the same map (a setting the method does not read)
/// keeps their outputs.
#[allow(clippy::too_many_arguments)]
fn layout_step(
    run: &mut Run,
    slot: &mut Slot<layout::Key, Layout>,
    planes: &mut Slot<PlanesKey, facets::planes::Guides>,
    film: &Film,
    pre: Gen,
    saliency: Option<Gen>,
    params: &StageParams,
    plan: &Plan,
) -> Result<()> {
    let key = layout::Key::new(&params.facets, pre, saliency);
    run.step(slot, key, plan.faceting.then_some(Stage::Faceting.name()), |run, old| {
        let mut warnings = Vec::new();
        let (layout, map) = if layout::planes_reuse_inputs(&params.facets, film) {
            let key = (pre, saliency, params.facets.planes.outlines);
            let fresh = !planes.hit(&key);
            let id = if fresh { run.new_gen() } else { 0 };
            run.progress.begin(Stage::Faceting.name(), 1);
            run.timings.time(Stage::Faceting.name(), || {
                let input = layout::planes_input(film);
                if fresh {
                    planes.put(Entry { key, id, value: facets::planes::guides(&input, key.2) });
                }
                facets::planes::layout_guided(&input, &params.facets.planes, planes.made())
            })
        } else {
            stages::layout_stage(&params.facets, film, run.progress, &mut run.timings, &mut warnings)?
        };
        let out = Layout { layout, map, warnings };
        Ok(match old {
            Some(o) if o.value.map == out.map => Made::Same(out, o.id),
            _ => Made::New(out),
        })
    })?;
    Ok(())
}

/// What the re-trace and the anti-aliasing trace through: the pre-render's tracer and camera,
/// the facet map and the aims, and the generations they came from.
struct Fresh<'a> {
    tracer: &'a Tracer<'a>,
    ctx: &'a AimContext<'a>,
    map: &'a FacetMap,
    aims: &'a [FacetAim],
    gens: Gens,
}

/// The aims, or those kept; the centre hits the cue check traced (for this run's re-trace
/// only) when they were made.
#[allow(clippy::too_many_arguments)]
fn aims_step(
    run: &mut Run,
    slot: &mut Slot<stages::aims::Key, Vec<FacetAim>>,
    prep: &Prepared,
    ctx: &AimContext,
    map: &FacetMap,
    film: &Film,
    gens: &Gens,
    params: &StageParams,
) -> Result<Option<CentreHits>> {
    let saliency = if params.aim.mode == AimMode::Saliency { gens.saliency } else { None };
    let key = stages::aims::Key { layout: gens.layout, pre: gens.pre, saliency, params: params.aim.clone() };
    let mut centre = None;
    run.step(slot, key, Some(Stage::Imprecision.name()), |run, old| {
        drop(old);
        let mesh = Some((prep, &params.saliency));
        let (aims, hits) = stages::aims_stage(ctx, map, film, &params.aim, mesh, None, run.progress, &mut run.timings);
        centre = hits;
        Ok(Made::New(aims))
    })?;
    Ok(centre)
}

/// The re-trace of the moved facets' pixels, or the one kept for these aims. One-off: in
/// place, after shading the other pixels of a deferred pre-render.
fn retrace_step(
    run: &mut Run,
    slot: &mut Slot<Gen, Delta>,
    fresh: &Fresh,
    film: &mut Film,
    unshaded: &mut bool,
    centre: Option<&CentreHits>,
    pixels_kept: &mut PixelsKept,
) -> Result<()> {
    let Fresh { tracer, ctx, map, aims, gens } = fresh;
    let aims_gen = gens.aims.expect("the aims are made before the re-trace");
    let name = (!slot.get().is_some_and(|d| d.pixels.is_empty())).then_some(Stage::ReTrace.name());
    run.step(slot, aims_gen, name, |run, old| {
        let moved = stages::moved_pixels(map, aims);
        let retracing = match run.policy {
            Policy::Kept => Retracing::Kept { pre: gens.pre, old: old.as_ref().map(|e| &e.value) },
            Policy::OneOff => {
                if std::mem::take(unshaded) {
                    stages::shade_stage(tracer, ctx, &moved, film, run.progress, &mut run.timings);
                    run.progress.check()?;
                }
                Retracing::InPlace
            }
        };
        let keeps = run.keeps();
        let out = stages::retrace_stage(
            tracer,
            ctx,
            map,
            aims,
            Some(moved),
            centre,
            film,
            retracing,
            run.progress,
            &mut run.timings,
        );
        if keeps {
            pixels_kept.retrace_kept = out.kept;
            pixels_kept.retrace_traced = out.traced;
        }
        Ok(Made::New(out.delta))
    })?;
    Ok(())
}

/// Anti-aliasing (`spp` samples where the single centre samples say the picture has an edge),
/// or the one kept. Kept runs keep the refined pixels' colours apart; one-off refines in place.
fn antialias_step(
    run: &mut Run,
    slot: &mut Slot<antialias::Key, ColourDelta>,
    fresh: &Fresh,
    trace: &crate::trace::TraceParams,
    film: &mut Film,
    delta: Option<&mut Delta>,
    pixels_kept: &mut PixelsKept,
) -> Result<()> {
    let Fresh { tracer, ctx, map, aims, gens } = fresh;
    let key = antialias::Key { film: gens.traced, layout: gens.layout, aims: gens.aims };
    run.step(slot, key, Some(Stage::AntiAliasing.name()), |run, old| {
        let refining = match run.policy {
            Policy::Kept => {
                let traced = delta.as_ref().and_then(|d| d.traced.clone());
                let traced = traced.unwrap_or_else(|| Arc::new(Traced::new(gens.pre, map, aims)));
                Refining::Kept { old: old.as_ref().map(|e| &e.value), traced }
            }
            Policy::OneOff => Refining::InPlace,
        };
        let keeps = run.keeps();
        let refined = with_film(film, Reads::All, delta, None, None, |film| {
            stages::antialias_stage(tracer, ctx, trace, map, aims, film, refining, run.progress, &mut run.timings)
        });
        if keeps {
            pixels_kept.antialiasing_kept = refined.pixels.len() - refined.traced_count;
            pixels_kept.antialiasing_traced = refined.traced_count;
        }
        Ok(Made::New(refined))
    })?;
    Ok(())
}

/// What the paint keeps in a lane.
struct PaintSlots<'a> {
    painter: &'a Slot<PainterKey, Painter>,
    inputs: &'a mut Slot<(Gen, Option<Gen>), PaintInputs>,
    prefix: &'a mut Slot<PrefixKey, Prefix>,
    paint: &'a mut Slot<paint::Key, Vec<Vec4>>,
}

/// The paint, or the one kept. A kept run paints from the first effect whose parameters
/// changed since the last paint of this film (the canvas before it was kept then) and keeps
/// the inputs the effects derive from the film's hits and the facet map.
#[allow(clippy::too_many_arguments)]
fn paint_step(
    run: &mut Run,
    slots: PaintSlots,
    prep: &Prepared,
    view: &View,
    picture: &mut Picture,
    map: &FacetMap,
    gens: &Gens,
    params: &StageParams,
    plan: &Plan,
) -> Result<()> {
    let PaintSlots { painter, inputs: inputs_slot, prefix: prefix_slot, paint: slot } = slots;
    let painter = painter.entry().expect("painter made first");
    let layout = plan.faceting.then_some(gens.layout);
    let key = paint::Key { film: gens.film, layout, painter: painter.id, pre: gens.pre };
    run.step(slot, key, Some(Stage::Paint.name()), |run, old| {
        drop(old);
        let f = &view.framed.frame;
        let axes = ViewAxes { right: f.right.as_vec3(), up: f.up.as_vec3(), forward: f.forward.as_vec3() };
        let lighting = view.rig.as_ref().map(|rig| Lighting { world: &prep.world, rig, view: axes });
        // An unfaceted image has no facet borders or corners: no facet map for the painter.
        let facets = plan.faceting.then_some(map);
        run.progress.begin(Stage::Paint.name(), 1);
        if run.policy == Policy::OneOff {
            // In place: no second colour buffer (tests/memory_bound.rs).
            let paint = |film: &mut Film| {
                let painting = Painting::InPlace;
                stages::paint_stage(&painter.value, film, facets, lighting.as_ref(), painting, &mut run.timings)
            };
            return picture.with(Reads::ColourAndHits, true, None, paint).map(|(c, _)| Made::New(c));
        }
        let inputs_key = (gens.traced, layout);
        if !inputs_slot.hit(&inputs_key) {
            let old = inputs_slot.take();
            let value = PaintInputs::kept_for_changes_after(old.as_ref().map(|e| &e.value));
            inputs_slot.put(Entry { key: inputs_key, id: run.new_gen(), value });
        }
        let inputs = inputs_slot.made();
        let base = PrefixKey { film: gens.film, layout, pre: gens.pre, palette: painter.key.palette };
        let keys = painter.value.keys();
        let prefix = prefix_slot.take().filter(|e| e.key == base);
        let agree = prefix.as_ref().map(|e| e.value.agreement(keys));
        let resume = prefix.as_ref().zip(agree).and_then(|(e, n)| e.value.resume(n));
        let keep_at = agree.filter(|&n| n > 0 && n < keys.len());
        // An opaque canvas resumed after every effect that reads the film's hits, with the
        // regions held, reads nothing of the film: its colour starts as the kept canvas, and
        // the moved and refined pixels need not be swapped in (nor out).
        let opaque = !params.paint.transparent;
        let film_read = !(opaque
            && resume.is_some_and(|(done, _)| *done > 0 && !painter.value.reads_hits_from(*done))
            && inputs.has_regions());
        let painting = Painting::Kept { inputs, resume, keep_at, opaque };
        let painted = picture.with(Reads::ColourAndHits, film_read, None, |film| {
            stages::paint_stage(&painter.value, film, facets, lighting.as_ref(), painting, &mut run.timings)
        });
        let (painted, kept) = match painted {
            Ok(p) => p,
            Err(e) => {
                if let Some(p) = prefix {
                    prefix_slot.put(p);
                }
                return Err(e);
            }
        };
        // The new snapshot, else the old one if the new chain still agrees with it.
        let n = agree.unwrap_or(0);
        let old = prefix.and_then(|e| e.value.snapshot).filter(|(done, _)| *done <= n);
        let snapshot = kept.or(old);
        prefix_slot.put(Entry { key: base, id: run.new_gen(), value: Prefix { keys: keys.to_vec(), snapshot } });
        Ok(Made::New(painted))
    })?;
    Ok(())
}

/// The pre-render's film as the stages after the re-trace see it: the re-trace's and the
/// anti-aliasing's kept pixels swapped in while a stage reads it.
struct Picture<'a> {
    film: &'a mut Film,
    delta: Option<&'a mut Delta>,
    aa: Option<&'a mut ColourDelta>,
}

impl Picture<'_> {
    /// Runs `f` on the film with the kept pixels swapped in when `film_read` (in the buffers
    /// `f` `reads`) and, when given, `colour` as its colour.
    fn with<T>(
        &mut self,
        reads: Reads,
        film_read: bool,
        colour: Option<&mut Vec<Vec4>>,
        f: impl FnOnce(&mut Film) -> T,
    ) -> T {
        if !film_read {
            return with_film(self.film, reads, None, None, colour, f);
        }
        with_film(self.film, reads, self.delta.as_deref_mut(), self.aa.as_deref_mut(), colour, f)
    }
}

/// Runs `f` on the film as the stages after the re-trace see it: the moved pixels swapped in
/// (in the buffers `f` `reads`), the refined ones, and, when given, the painted colour; all
/// are swapped back out afterwards, whatever `f` returns.
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
