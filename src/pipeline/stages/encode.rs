//! The encode stage: the output image and the passes the settings ask for.

use image::RgbaImage;

use crate::facets::{self, FacetMap};
use crate::film::Film;
use crate::imprecision::{self, FacetAim};
use crate::output::passes::{facet_ids_pass, facets_pass, geometry_pass};
use crate::output::{Gray16, Pass, encode};
use crate::pipeline::cache::Gen;
use crate::pipeline::{StageParams, Timings};

/// What the encoding reads.
#[derive(PartialEq)]
pub struct Key {
    /// The colour encoded: the paint's, else the film's.
    pub colour: Gen,
    pub film: Gen,
    pub layout: Gen,
    pub aims: Option<Gen>,
    pub saliency: Option<Gen>,
    pub passes: Vec<Pass>,
    pub background: [f32; 3],
    pub transparent: bool,
    pub neighbourhood: f64,
    pub scale: f64,
}

/// The encoded image and passes.
#[derive(Clone)]
pub struct Encoded {
    pub image: RgbaImage,
    pub passes: Vec<(Pass, RgbaImage)>,
    /// Passes stored as 16-bit grey (facet ids).
    pub passes16: Vec<(Pass, Gray16)>,
}

impl Encoded {
    pub fn bytes(&self) -> u64 {
        let image = |i: &RgbaImage| i.as_raw().len() as u64;
        image(&self.image)
            + self.passes.iter().map(|(_, i)| image(i)).sum::<u64>()
            + self.passes16.iter().map(|(_, i)| i.as_raw().len() as u64 * 2).sum::<u64>()
    }
}

/// The output image of `film` and the passes `params` ask for.
pub fn encode_stage(
    film: &Film,
    map: &FacetMap,
    aims: &[FacetAim],
    params: &StageParams,
    timings: &mut Timings,
) -> Encoded {
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
    Encoded { image, passes, passes16 }
}
