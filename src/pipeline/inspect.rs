//! `cubist facets`: the Segment faceting of a view, with the images that show how it was made
//! (the thesis's Fig. 4.5): the pre-render, its saliency, the superpixels, each level, the
//! final layout.

use image::RgbaImage;

use super::stages::{encode_stage, layout, saliency_stage};
use super::{PreRender, Prepared, Shading, Stage, StageParams, Timings, prerender};
use crate::error::Result;
use crate::facets::FacetLayout;
use crate::facets::segment::{self, SegmentLevels, inspection};
use crate::output::Pass;
use crate::progress::Progress;
use crate::settings::Settings;

/// What `cubist facets` shows: the pre-render, the layout and the inspection images.
pub struct Inspection {
    /// The pre-render (Fig. 4.5 a).
    pub view: RgbaImage,
    /// (pass name, image): `layout` always; with `--pass segments` also `superpixels`,
    /// `level1`.. and the saliency pass; any other pass the settings ask for that needs no facets.
    pub images: Vec<(String, RgbaImage)>,
    pub layout: FacetLayout,
    pub levels: SegmentLevels,
    /// The pre-render's steps, then `faceting` for the whole segmentation (its own steps are
    /// in `levels.timings`).
    pub timings: Timings,
    pub warnings: Vec<String>,
}

/// What the faceting stage of a render of `params` sees: the pre-render (lit) with its
/// saliency map, whether or not the render itself would need the map.
pub fn faceting_input(
    prep: &Prepared,
    params: &StageParams,
    progress: &Progress,
    timings: &mut Timings,
) -> Result<PreRender> {
    let mut pre = prerender(prep, &params.framing, &params.trace, Shading::Lit, progress, timings)?;
    pre.film.saliency = Some(saliency_stage(prep, &pre.film, &params.saliency, progress, timings)?.1);
    Ok(pre)
}

/// Pre-renders `settings`' view, computes its Segment layout and the inspection images.
pub fn inspect_facets(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<Inspection> {
    settings.validate()?;
    let params = StageParams::new(settings);
    layout::check_work(&params.facets)?;
    let mut timings = Timings::default();
    let PreRender { film, mut warnings, .. } = faceting_input(prep, &params, progress, &mut timings)?;

    // The pre-render's image and passes as an unfaceted, unpainted render shows them; the
    // passes that need facets are the layout images below.
    let mut shown = params.clone();
    let single = FacetLayout::single().rasterize(film.width, film.height);
    let show_levels = params.passes.contains(&Pass::Segments);
    shown.passes.retain(|p| !matches!(p, Pass::Segments | Pass::Facets | Pass::FacetIds));
    if show_levels && !shown.passes.contains(&Pass::Saliency) {
        shown.passes.push(Pass::Saliency);
    }
    let encoded = encode_stage(&film, &single, &[], &shown, &mut timings);
    let (view, passes) = (encoded.image, encoded.passes);

    progress.begin(Stage::Faceting.name(), 1);
    let (layout, levels) = timings.time(Stage::Faceting.name(), || segment::layout(&film, &params.facets.segment))?;
    progress.finish();

    let mut images: Vec<(String, RgbaImage)> =
        passes.into_iter().map(|(pass, img)| (pass.as_str().to_string(), img)).collect();
    if show_levels {
        images.extend(inspection::images(&levels, &layout, &view));
    } else {
        images.push(("layout".into(), inspection::layout_image(&layout, film.width, film.height)));
    }
    warnings.extend(levels.warnings.iter().cloned());
    Ok(Inspection { view, images, layout, levels, timings, warnings })
}
