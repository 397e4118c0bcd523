//! The faceting stage: the facet layout computed from the pre-render, or
//! loaded so every frame of an animation shares it, rasterised at the image's size.

use crate::error::Result;
use crate::facets::{self, FacetLayout, FacetMap, FacetMethod, FacetParams};
use crate::film::Film;
use crate::pipeline::cache::{Gen, file_key};
use crate::pipeline::{Stage, Timings};
use crate::progress::Progress;

/// What the layout reads: its parameters, the contents of the files it loads, and the
/// pre-render and saliency map for methods that follow the picture (`reads_picture`).
#[derive(PartialEq)]
pub struct Key {
    pub params: FacetParams,
    /// Contents of the layout file and the facet map image.
    pub files: [Option<u128>; 2],
    pub picture: Option<(Gen, Option<Gen>)>,
}

impl Key {
    pub fn new(params: &FacetParams, pre: Gen, saliency: Option<Gen>) -> Key {
        Key {
            params: params.clone(),
            files: [file_key(params.layout_file.as_deref()), file_key(params.facet_map.as_deref())],
            picture: reads_picture(params).then_some((pre, saliency)),
        }
    }
}

/// What the planes faceting's kept inputs were made from: the pre-render, the saliency map,
/// whether outlines are cut.
pub type PlanesKey = (Gen, Option<Gen>, bool);

/// The faceting's output: the layout, its map at this size, and what it warned of.
pub struct Layout {
    pub layout: FacetLayout,
    pub map: FacetMap,
    pub warnings: Vec<String>,
}

/// Whether a faceting method reads the pre-render (its layout follows the picture). An
/// exhaustive match: a new method must say.
pub fn reads_picture(params: &FacetParams) -> bool {
    if params.layout_file.is_some() {
        return false;
    }
    match params.method {
        FacetMethod::Segment | FacetMethod::Planes => true,
        FacetMethod::None | FacetMethod::Constant | FacetMethod::Voronoi | FacetMethod::Patch => false,
    }
}

/// Work that would take hours, refused before anything runs: the Segment faceting's
/// eigenvectors. (The lights' work depends on the scene: the pre-render checks it.)
pub fn check_work(params: &FacetParams) -> Result<()> {
    if params.method == FacetMethod::Segment && params.layout_file.is_none() {
        facets::segment::check_work(params.width, params.height, &params.segment)?;
    }
    Ok(())
}

/// The layout from `film` (a pre-render; read by the methods that follow the picture), or
/// loaded, rasterised at the parameters' size. Unfaceted: one facet.
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

/// Whether the planes faceting can start from inputs kept for this pre-render
/// (`facets::planes::guides`): planes made here, at the pre-render's size.
pub fn planes_reuse_inputs(params: &FacetParams, film: &Film) -> bool {
    params.method == FacetMethod::Planes
        && params.layout_file.is_none()
        && (film.width, film.height) == (params.width, params.height)
}

/// What the planes faceting reads of `film`, whatever its plane count and detail.
pub fn planes_input(film: &Film) -> facets::planes::PlanesInput<'_> {
    facets::planes::PlanesInput {
        width: film.width,
        height: film.height,
        hits: &film.hits,
        saliency: film.saliency.as_deref(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::Settings;

    #[test]
    fn every_faceting_method_says_whether_it_reads_the_picture() {
        let base = crate::pipeline::params::facets(&Settings::default());
        assert!(reads_picture(&FacetParams { method: FacetMethod::Segment, ..base.clone() }));
        assert!(!reads_picture(&FacetParams { method: FacetMethod::Voronoi, ..base.clone() }));
        let loaded = FacetParams { layout_file: Some("l.json".into()), method: FacetMethod::Segment, ..base };
        assert!(!reads_picture(&loaded));
    }
}
