//! The anti-aliasing stage: the pixels that need them (all with `aa_threshold` 0) get `spp`
//! samples each through their facet's rays, the pre-render's and re-trace's single centre
//! samples telling which (`trace::pixels_to_refine`). A kept run keeps the refined pixels'
//! colours apart from the film (`ColourDelta`), and the next anti-aliasing reuses those
//! refined again through the same rays with the same lights known.

use std::sync::Arc;

use glam::Vec4;

use super::retrace::{Traced, facet_rays};
use crate::facets::FacetMap;
use crate::film::Film;
use crate::imprecision::{AimContext, FacetAim};
use crate::pipeline::cache::Gen;
use crate::pipeline::{Stage, Timings};
use crate::progress::Progress;
use crate::trace::{TraceParams, Tracer};

/// What the anti-aliasing reads: the film refined (the re-trace's, or the pre-render's), the
/// layout and the aims.
#[derive(PartialEq)]
pub struct Key {
    pub film: Gen,
    pub layout: Gen,
    pub aims: Option<Gen>,
}

/// How the anti-aliasing leaves its work.
pub enum Refining<'a> {
    /// In the film's colour (a one-off render, an animation frame).
    InPlace,
    /// Apart from the film (`ColourDelta`; the film's colour is left as it was), taking the
    /// colour of each pixel refined by `old` through the same rays (`traced`: what this run
    /// traces through) with the same lights known.
    Kept { old: Option<&'a ColourDelta>, traced: Arc<Traced> },
}

/// The anti-aliasing's output in a kept run: the refined pixels' colours, swapped into the
/// film (over the re-trace's delta) while a later stage reads it.
#[derive(Default)]
pub struct ColourDelta {
    pub pixels: Vec<u32>,
    color: Vec<Vec4>,
    /// Each pixel's `trace::antialias_known`, and the rays it was refined through.
    known: Vec<u64>,
    traced: Option<Arc<Traced>>,
    /// How many of `pixels` this run traced (the others were the previous run's).
    pub traced_count: usize,
}

impl ColourDelta {
    pub fn swap(&mut self, film: &mut Film) {
        for (k, &i) in self.pixels.iter().enumerate() {
            std::mem::swap(&mut self.color[k], &mut film.color[i as usize]);
        }
    }

    pub fn bytes(&self) -> u64 {
        (self.pixels.len() * 4 + self.color.len() * size_of::<Vec4>() + self.known.len() * 8) as u64
            + self.traced.as_ref().map_or(0, |t| t.bytes())
    }
}

/// Refines the pixels of `film` that need it through their facets' rays with `tracer` (the
/// pre-render's, or an animation frame's posed scene and lights) and the camera of `ctx`.
#[allow(clippy::too_many_arguments)]
pub fn antialias_stage(
    tracer: &Tracer,
    ctx: &AimContext,
    trace: &TraceParams,
    map: &FacetMap,
    aims: &[FacetAim],
    film: &mut Film,
    refining: Refining,
    progress: &Progress,
    timings: &mut Timings,
) -> ColourDelta {
    use rayon::prelude::*;
    let rays = facet_rays(ctx, map, aims);
    let Refining::Kept { old, traced } = refining else {
        timings.time(Stage::AntiAliasing.name(), || {
            let ids = aa_facets(map, aims);
            let ids: &[u32] = &ids;
            let pixels = crate::trace::pixels_to_refine(film, ids, trace.aa_threshold);
            progress.begin(Stage::AntiAliasing.name(), pixels.len() as u64);
            tracer.antialias(film, &rays, &pixels, ids, trace.spp, progress);
        });
        progress.finish();
        return ColourDelta::default();
    };
    // The previous anti-aliasing's colour of a pixel refined again through the same rays
    // with the same lights known (`Traced::same`; what it reads of its neighbours is in
    // `known`).
    let old = old.and_then(|o| o.traced.as_ref().map(|t| (o, t)));
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
    let out = timings.time(Stage::AntiAliasing.name(), || {
        let ids = aa_facets(map, aims);
        let ids: &[u32] = &ids;
        let pixels = crate::trace::pixels_to_refine(film, ids, trace.aa_threshold);
        let known: Vec<u64> =
            pixels.par_iter().map(|&i| crate::trace::antialias_known(film, ids, i as usize)).collect();
        let mut colours: Vec<Option<Vec4>> = pixels.par_iter().zip(&known).map(|(&i, &k)| reuse(i, k)).collect();
        let again: Vec<u32> = pixels.iter().zip(&colours).filter(|(_, c)| c.is_none()).map(|(&i, _)| i).collect();
        progress.begin(Stage::AntiAliasing.name(), again.len() as u64);
        let before: Vec<Vec4> = again.iter().map(|&i| film.color[i as usize]).collect();
        tracer.antialias(film, &rays, &again, ids, trace.spp, progress);
        let mut traced = again.iter().zip(before).map(|(&i, c)| std::mem::replace(&mut film.color[i as usize], c));
        let color = colours.iter_mut().map(|c| c.take().or_else(|| traced.next()).unwrap_or_default()).collect();
        ColourDelta { pixels, color, known, traced: None, traced_count: again.len() }
    });
    progress.finish();
    ColourDelta { traced: Some(traced), ..out }
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
