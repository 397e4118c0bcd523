//! The imprecision stage: each facet's centres, the point it is
//! aimed at and its new rays, within what a facet may show (the backdrop held, shifts
//! bounded, the most salient vertices kept in view).

use crate::facets::FacetMap;
use crate::film::Film;
use crate::imprecision::cues::CentreHits;
use crate::imprecision::{self, AimContext, AimParams, FacetAim};
use crate::pipeline::cache::Gen;
use crate::pipeline::{Prepared, Stage, Timings, View};
use crate::progress::Progress;
use crate::saliency::SaliencyParams;
use crate::trace::TraceParams;

/// What the aims read: the layout, the pre-render, the saliency map when the mode reads it,
/// and their parameters.
#[derive(PartialEq)]
pub struct Key {
    pub layout: Gen,
    pub pre: Gen,
    pub saliency: Option<Gen>,
    pub params: AimParams,
}

/// What re-aiming needs of the pre-render's camera and the scene.
pub fn aim_context<'a>(prep: &'a Prepared, view: &'a View, trace: &TraceParams) -> AimContext<'a> {
    let clip_radius = (prep.world.radius as f64).max(1e-9) * 1.001;
    AimContext {
        camera: view.framed.camera.as_ref(),
        accel: &prep.accel,
        width: trace.width,
        height: trace.height,
        clip_radius,
        up: view.framed.frame.up,
    }
}

/// One `FacetAim` per facet of `map`, and the centre hits the cue check traced through the
/// aims kept (`imprecision::cues::CentreHits`), which the re-trace takes instead of tracing
/// them again. `mesh`: the scene whose pre-render `film` is and how its mesh saliency was
/// computed, to keep its most salient vertices in view (None: not checked, e.g. a posed
/// animation frame). `held`: the turns another frame decided (per facet, radians; a sequence's
/// layout frame under static facets), made here instead of deciding them again.
#[allow(clippy::too_many_arguments)]
pub fn aims_stage(
    ctx: &AimContext,
    map: &FacetMap,
    film: &Film,
    params: &AimParams,
    mesh: Option<(&Prepared, &SaliencyParams)>,
    held: Option<&[f64]>,
    progress: &Progress,
    timings: &mut Timings,
) -> (Vec<FacetAim>, Option<CentreHits>) {
    progress.begin(Stage::Imprecision.name(), 1);
    timings.time(Stage::Imprecision.name(), || {
        // Every facet's pixels, made once for the centres, the coverage and the cue checks.
        let by_facet = map.facet_pixels();
        let mut aims = imprecision::aim_facets_with(ctx, map, &by_facet, film.saliency.as_deref(), params);
        // The mesh saliency is the memo's since the saliency stage (a failure there was
        // reported there).
        let saliency = mesh
            .filter(|_| params.reads_saliency() && film.saliency.is_some())
            .and_then(|(prep, p)| crate::saliency::for_film(&prep.scene, &prep.world, &prep.saliency, film, p).ok());
        let cues = mesh.zip(saliency.as_ref()).and_then(|((prep, p), s)| {
            imprecision::cues::CueVertices::new(&prep.scene, &prep.world, &s.per_mesh, p.reads_parts())
        });
        let hits = imprecision::guard::apply(&mut aims, ctx, map, &by_facet, film, cues.as_ref(), params);
        // Turned views last: they turn the rays the rules above settled.
        match held {
            Some(angles) => imprecision::views::turn_held(&mut aims, ctx, &by_facet, film, angles),
            None => imprecision::views::turn_views(&mut aims, ctx, &by_facet, film, params),
        };
        (aims, hits)
    })
}
