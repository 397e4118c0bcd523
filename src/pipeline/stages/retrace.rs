//! The re-trace stage: the pixels of facets whose rays moved, traced again through their
//! facet's rays (`facet_rays`) with the pre-render's tracer; and, after a deferred pre-render
//! (`Shading::Deferred`), the shading of the pixels it keeps. A kept run keeps the re-traced
//! pixels apart from the pre-render's film (`Delta`), and the next re-trace puts back those
//! traced through the same rays reading the same neighbours (`Traced::same`).

use std::sync::Arc;

use glam::{DVec2, Vec4};

use crate::camera::CameraRay;
use crate::facets::FacetMap;
use crate::film::{Film, PixelHit, SampleHit};
use crate::imprecision::cues::CentreHits;
use crate::imprecision::{self, AimContext, FacetAim};
use crate::pipeline::cache::Gen;
use crate::pipeline::{Stage, Timings};
use crate::progress::Progress;
use crate::trace::{KnownHits, Tracer};

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
pub fn shade_stage(
    tracer: &Tracer,
    ctx: &AimContext,
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
    let rays = ctx.camera.centre_rays(film.width, film.height);
    timings.time("shading", || tracer.shade_traced(film, &*rays, &kept, progress));
    progress.finish();
}

/// How the re-trace leaves its work.
pub enum Retracing<'a> {
    /// In the film (a one-off render, an animation frame).
    InPlace,
    /// Apart from the film (`Delta`), over the pre-render `pre`, reusing the pixels of the
    /// previous re-trace (`old`) traced through the same rays.
    Kept { pre: Gen, old: Option<&'a Delta> },
}

/// What the re-trace did: the moved pixels as traced (kept runs; else empty) and how many
/// pixels it kept from the previous re-trace and traced.
pub struct Retraced {
    pub delta: Delta,
    pub kept: usize,
    pub traced: usize,
}

/// Traces `pixels` of `film` (None: every pixel, the progress counted by the caller's
/// stage) through their facets' rays with `tracer` (the pre-render's lights, background and
/// samples), overwriting their colour, hits and samples. `centre`: the cue check's hits of
/// these very centre rays (`aims_stage`), taken instead of tracing them again where they are
/// the hits of `aims`. At one sample per pixel, shadow rays are cast sparsely
/// (`Tracer::render`).
#[allow(clippy::too_many_arguments)]
pub fn retrace_stage(
    tracer: &Tracer,
    ctx: &AimContext,
    map: &FacetMap,
    aims: &[FacetAim],
    pixels: Option<Vec<u32>>,
    centre: Option<&CentreHits>,
    film: &mut Film,
    retracing: Retracing,
    progress: &Progress,
    timings: &mut Timings,
) -> Retraced {
    let Retracing::Kept { pre, old } = retracing else {
        let traced = pixels.as_ref().map_or(film.pixel_count(), Vec::len);
        trace_pixels(tracer, ctx, map, aims, pixels.as_deref(), centre, film, progress, timings);
        return Retraced { delta: Delta::default(), kept: 0, traced };
    };
    // The originals, then the re-trace in place, then swapped: the film is the pre-render's
    // again and the delta holds the moved pixels as traced again.
    let pixels = pixels.unwrap_or_else(|| (0..film.pixel_count() as u32).collect());
    let mut delta = Delta::gather(film, pixels);
    let traced = Arc::new(Traced::new(pre, map, aims));
    // Pixels the previous re-trace traced through the same rays, reading the same
    // neighbours: put back as they were; the others traced again.
    let (w, h) = (film.width as usize, film.height as usize);
    let mut again = Vec::with_capacity(delta.pixels.len());
    let old = old.and_then(|d| d.traced.as_ref().map(|t| (d, t))).filter(|(_, t)| t.may_share_rays(&traced));
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
    let kept = delta.pixels.len() - again.len();
    let traced_count = again.len();
    trace_pixels(tracer, ctx, map, aims, Some(&again), centre, film, progress, timings);
    delta.swap(film);
    delta.traced = Some(traced);
    Retraced { delta, kept, traced: traced_count }
}

/// `retrace_stage`'s trace, in place.
#[allow(clippy::too_many_arguments)]
fn trace_pixels(
    tracer: &Tracer,
    ctx: &AimContext,
    map: &FacetMap,
    aims: &[FacetAim],
    pixels: Option<&[u32]>,
    centre: Option<&CentreHits>,
    film: &mut Film,
    progress: &Progress,
    timings: &mut Timings,
) {
    if pixels.is_some_and(|p| p.is_empty()) {
        return;
    }
    if let Some(p) = pixels {
        progress.begin(Stage::ReTrace.name(), p.len() as u64);
    }
    // The hits hold for the pre-render's scene and camera (`ctx`) at one sample per pixel.
    let centre = centre.filter(|_| std::ptr::eq(tracer.accel, ctx.accel) && film.width == ctx.width);
    let known = centre.map(|c| c.known(map, aims));
    let rays = facet_rays(ctx, map, aims);
    timings.time(Stage::ReTrace.name(), || {
        let known = known.as_ref().map(|k| k as &KnownHits);
        tracer.render_known(film, &rays, pixels, Some(&map.ids), known, progress)
    });
    if pixels.is_some() {
        progress.finish();
    }
}

/// The re-trace's output in a kept run: the moved facets' pixels as traced again. Kept apart
/// from the pre-render's film and swapped into it while a later stage reads it (swapping
/// twice leaves the film as it was), so a facet change copies the moved pixels, not the
/// whole film.
#[derive(Default)]
pub struct Delta {
    pub pixels: Vec<u32>,
    color: Vec<Vec4>,
    hits: Vec<PixelHit>,
    occlusion: Vec<u8>,
    samples: Vec<SampleHit>,
    /// What the pixels were traced through (the next re-trace reuses the pixels whose rays
    /// and facet neighbours are the same, `Traced::same`).
    pub traced: Option<Arc<Traced>>,
}

/// Which of the film's per-pixel buffers a stage reads (`Delta::swap_read`).
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Reads {
    All,
    /// The paint reads the colour and the hits alone (`Painter::apply_from`).
    ColourAndHits,
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
    pub fn swap(&mut self, film: &mut Film) {
        self.swap_read(film, Reads::All);
    }

    /// Exchanges the delta's pixels with the film's in the buffers a stage reads (`Reads`):
    /// swapping twice leaves the film as it was either way. The colour and hits on one
    /// thread, the occlusion and samples on another (disjoint buffers).
    pub fn swap_read(&mut self, film: &mut Film, reads: Reads) {
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

    pub fn bytes(&self) -> u64 {
        (self.pixels.len() * 4
            + self.traced.as_ref().map_or(0, |t| t.ids.len() * 4)
            + self.color.len() * size_of::<Vec4>()
            + self.hits.len() * size_of::<PixelHit>()
            + self.occlusion.len()
            + self.samples.len() * size_of::<SampleHit>()) as u64
    }
}

/// A facet's rays as a trace reads them: None for the camera's (not moved), else its re-aim,
/// linear facet and turn.
type FacetRays = Option<(Option<imprecision::Reaim>, Option<imprecision::Linear>, Option<imprecision::Turn>)>;

fn facet_rays_of(aim: &FacetAim) -> FacetRays {
    aim.moved().then_some((aim.reaim, aim.linear, aim.turn))
}

/// The facet map and each facet's rays a re-trace and an anti-aliasing traced through, and
/// the pre-render they traced over.
pub struct Traced {
    pre: Gen,
    ids: Vec<u32>,
    rays: Vec<FacetRays>,
}

impl Traced {
    pub fn new(pre: Gen, map: &FacetMap, aims: &[FacetAim]) -> Traced {
        Traced { pre, ids: map.ids.clone(), rays: aims.iter().map(facet_rays_of).collect() }
    }

    pub fn bytes(&self) -> u64 {
        self.ids.len() as u64 * 4
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
    pub fn same(&self, new: &Traced, i: usize, neighbours: impl Iterator<Item = usize>) -> bool {
        if self.pre != new.pre || self.ids.len() != new.ids.len() || self.rays_at(i) != new.rays_at(i) {
            return false;
        }
        let (a, b) = (self.ids[i], new.ids[i]);
        neighbours.into_iter().all(|j| (self.ids[j] == a) == (new.ids[j] == b))
    }
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
}
