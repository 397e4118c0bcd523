//! The saliency stage: mesh saliency of the meshes the pre-render hit,
//! and the per-pixel saliency map read off the same samples (no second trace).

use crate::error::Result;
use crate::film::Film;
use crate::pipeline::cache::Gen;
use crate::pipeline::{Prepared, Stage, Timings};
use crate::progress::Progress;
use crate::saliency::{MeshSaliency, SaliencyMethod, SaliencyParams};

/// What the saliency map reads: the pre-render and the method.
#[derive(Clone, Copy, PartialEq)]
pub struct Key {
    pub pre: Gen,
    pub method: SaliencyMethod,
    pub parts: f32,
}

/// Mesh saliency and the saliency map of `film` (a pre-render of `prep`).
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
            let map = crate::saliency::saliency_map(&prep.world, &sal, film, params);
            (sal, map)
        })
    })?;
    progress.finish();
    Ok(out)
}
