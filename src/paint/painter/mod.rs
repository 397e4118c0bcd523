//! The `Painter`: the enabled effects of a render, in chain order, run over a film's colour.

use glam::Vec4;
use rayon::prelude::*;

use super::brushwork::median_size;
use super::context::{Canvas, Lighting, PaintContext};
use super::effect::{Effect, key_of};
use super::inputs::{PaintInputs, figure_ground, ground_shares, open_planes};
use super::params::PaintParams;
use super::sequence::{Held, Sequence};
use crate::error::{Error, Result};
use crate::facets::FacetMap;
use crate::film::Film;

/// The enabled effects of a render, in chain order. Built once per settings (it loads the
/// palette painting), reusable for every frame of an animation.
pub struct Painter {
    effects: Vec<Box<dyn Effect>>,
    /// Each effect's key (`Painter::keys`); empty when not known.
    keys: Vec<u128>,
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
        let chain = p.chain();
        let effects = chain.iter().map(|e| e.build()).collect::<Result<Vec<_>>>()?;
        // Each effect's key, with what every effect reads of the canvas.
        let keys = chain.iter().map(|e| key_of(&(e.key(), p.background, p.transparent))).collect();
        Ok(Painter { effects, keys, background: p.background, transparent: p.transparent, open_planes: p.open_planes })
    }

    /// Each enabled effect's key (`EffectParams`, with the canvas's background and
    /// transparency), in chain order: two painters whose first k keys agree leave the same
    /// canvas after their first k effects (on the same film, facet map and lights; a palette
    /// painting's contents are not in its key).
    pub fn keys(&self) -> &[u128] {
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

    /// What a sequence holds from `film` (its layout frame's picture: `sequence::Held`):
    /// which planes are open across the outline, from its hits; the palette's luminance
    /// mapping of it painted by the effects before the palette; the brushwork's background
    /// and open regions' means of it painted by the effects before the brushwork, each
    /// effect reading what is held so far (as a frame of the sequence paints).
    pub fn hold(
        &self,
        film: &Film,
        facets: Option<&FacetMap>,
        lighting: Option<&Lighting>,
        sequence: &Sequence,
    ) -> Result<Held> {
        // Each plane's figure and ground pixels, counted once for both.
        let counts =
            facets.filter(|f| f.ids.len() == film.hits.len()).map(|f| figure_ground(&f.ids, &film.hits, f.id_bound()));
        let open = counts.as_deref().filter(|_| self.open_planes).map(open_planes);
        let ground = counts.as_deref().map(ground_shares);
        let plane_median = counts.as_deref().and_then(|c| median_size(c.iter().map(|&(a, b)| a + b)));
        let mut held = Held { open, ground, plane_median, ..Held::default() };
        let mut color = film.color.clone();
        let mut canvas = Canvas::new(film.width, film.height, &mut color, self.background, self.transparent);
        let inputs = PaintInputs::default();
        for e in &self.effects {
            let now = held.clone();
            let sequence = Sequence { held: Some(&now), ..*sequence };
            let ctx = PaintContext {
                hits: &film.hits,
                facets,
                lighting,
                inputs: &inputs,
                open_planes: self.open_planes,
                sequence: Some(&sequence),
            };
            if let Some(key) = e.palette_key(&canvas, &ctx) {
                held.palette = Some(key);
                // The palette paints this picture as the frames will, through the key.
                let now = held.clone();
                let sequence = Sequence { held: Some(&now), ..sequence };
                e.apply(&mut canvas, &PaintContext { sequence: Some(&sequence), ..ctx })?;
                continue;
            }
            if let Some(means) = e.region_means(&canvas, &ctx) {
                held.means = Some(means);
                break;
            }
            e.apply(&mut canvas, &ctx)?;
        }
        Ok(held)
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

#[cfg(test)]
mod tests;
