//! The paint stage: the painterly effects (`paint::Painter`) over the film's colour. A kept
//! run paints a copy of the colour and keeps the canvas part-way through the chain
//! (`Prefix`), so a change of one effect paints again from that effect on.

use glam::Vec4;

use crate::error::Result;
use crate::facets::FacetMap;
use crate::film::Film;
use crate::paint::{Lighting, PaintInputs, PaintParams, Painter, Resume, Sequence};
use crate::pipeline::cache::Gen;
use crate::pipeline::{Stage, Timings};

/// What the painter reads: its parameters and the palette painting's contents.
#[derive(PartialEq)]
pub struct PainterKey {
    pub params: PaintParams,
    pub palette: Option<u128>,
}

/// What the paint reads.
#[derive(PartialEq)]
pub struct Key {
    /// The film painted: the anti-aliasing's, the re-trace's, or the pre-render's.
    pub film: Gen,
    pub layout: Option<Gen>,
    pub painter: Gen,
    /// The lights chiaroscuro relights with.
    pub pre: Gen,
}

/// What the painted canvas kept part-way through the chain (`Prefix`) was painted over: the
/// film, the facet map, the lights, the palette painting's contents.
#[derive(Clone, PartialEq)]
pub struct PrefixKey {
    pub film: Gen,
    pub layout: Option<Gen>,
    pub pre: Gen,
    pub palette: Option<u128>,
}

/// The effect keys of the last chain painted over a `PrefixKey`, and the canvas before the
/// first effect that changed then (the effects before it agreed with the chain before).
pub struct Prefix {
    pub keys: Vec<u128>,
    /// Effects done, and the canvas after them.
    pub snapshot: Option<(usize, Vec<Vec4>)>,
}

impl Prefix {
    /// How many effects of the chain `keys` agree with the chain this prefix was painted by.
    pub fn agreement(&self, keys: &[u128]) -> usize {
        self.keys.iter().zip(keys).take_while(|(a, b)| a == b).count()
    }

    /// The kept canvas a chain agreeing on `agree` effects can resume from.
    pub fn resume(&self, agree: usize) -> Option<&(usize, Vec<Vec4>)> {
        self.snapshot.as_ref().filter(|(done, _)| *done <= agree)
    }

    pub fn bytes(&self) -> u64 {
        self.snapshot.as_ref().map_or(0, |(_, px)| (px.len() * size_of::<Vec4>()) as u64)
    }
}

/// How the paint leaves its work.
pub enum Painting<'a> {
    /// In the film's colour (a one-off render: no second colour buffer).
    InPlace,
    /// In the film's colour, as a frame of a sequence (`Painter::apply_sequence`: the palette,
    /// the planes and the strokes' seeds held for the sequence).
    Sequence(&'a Sequence<'a>),
    /// In a copy of the colour (the film's is left as it was), reading and filling `inputs`
    /// (made for this film's hits and facet map), resuming from a canvas kept part-way
    /// (`resume`: effects done and the canvas) and keeping the canvas after `keep_at` effects.
    /// `opaque`: no transparent background, so the canvas is the colour itself.
    Kept { inputs: &'a PaintInputs, resume: Option<&'a (usize, Vec<Vec4>)>, keep_at: Option<usize>, opaque: bool },
}

/// Paints `film` with `painter` (`facets`: None for an unfaceted image, which has no facet
/// borders or corners). Returns the painted colour (empty when painted in place) and the
/// canvas kept part-way through the chain (effects done, pixels).
#[allow(clippy::type_complexity)]
pub fn paint_stage(
    painter: &Painter,
    film: &mut Film,
    facets: Option<&FacetMap>,
    lighting: Option<&Lighting>,
    painting: Painting,
    timings: &mut Timings,
) -> Result<(Vec<Vec4>, Option<(usize, Vec<Vec4>)>)> {
    let (inputs, resume, keep_at, opaque) = match painting {
        Painting::InPlace => {
            timings.time(Stage::Paint.name(), || painter.apply(film, facets, lighting))?;
            return Ok((Vec::new(), None));
        }
        Painting::Sequence(sequence) => {
            timings.time(Stage::Paint.name(), || painter.apply_sequence(film, facets, lighting, sequence))?;
            return Ok((Vec::new(), None));
        }
        Painting::Kept { inputs, resume, keep_at, opaque } => (inputs, resume, keep_at, opaque),
    };
    // (Opaque: the canvas is the colour itself, so the kept one is copied once.)
    let (mut colour, resume) = match resume {
        Some((done, px)) if opaque => (px.clone(), Some(Resume { done: *done, px: None })),
        r => (film.color.clone(), r.map(|(done, px)| Resume { done: *done, px: Some(px) })),
    };
    std::mem::swap(&mut film.color, &mut colour);
    let r = timings.time(Stage::Paint.name(), || painter.apply_from(film, facets, lighting, inputs, resume, keep_at));
    std::mem::swap(&mut film.color, &mut colour);
    r.map(|kept| (colour, kept.map(|px| (keep_at.unwrap_or(0), px))))
}
