//! The render pipeline of thesis Fig. 4.1, its front door. `params` turns the validated
//! settings into each stage's own parameters; `stages` holds the stages, each a function of
//! plain values returning its output and the key of what it read; `run` runs them in order,
//! each only when its key changed since the output its lane keeps (`cache`): with nothing
//! kept for `render`, with a `Session`'s lanes for `cubist serve`. Animation frames
//! (`frames`) drive the same stages frame by frame.
//!
//! The other products of the pre-render: `saliency_map` (`cubist saliency`),
//! `inspect_facets` (`cubist facets`), `evaluate` (`cubist faces`) and `look` (`cubist look`).

pub mod cache;
mod faces;
mod follow_frame;
pub mod frames;
mod inspect;
mod look;
pub mod params;
mod prepared;
mod run;
mod saliency_map;
mod session;
mod stage;
pub mod stages;

use image::RgbaImage;

use crate::error::Result;
use crate::facets::{FacetLayout, FacetMap};
use crate::film::Film;
use crate::imprecision::FacetAim;
use crate::output::{Gray16, Pass};
use crate::progress::Progress;
use crate::settings::Settings;

pub use faces::{evaluate, visible_faces};
pub use follow_frame::{follows_saved_key, render_followed_frame};
pub use frames::{DEFAULT_FPS, FrameOutput, FramesParams, FramesSummary, render_frames};
pub use inspect::{Inspection, faceting_input, inspect_facets};
pub use look::{Look, look};
pub use params::StageParams;
pub use prepared::Prepared;
pub use run::{Frame, PixelsKept};
pub use saliency_map::{SaliencyRender, saliency_map};
pub use session::{DEFAULT_BUDGET, LANES, LaneStats, SceneUpdate, Session, SessionStats};
pub use stage::{MESH_SALIENCY_OVERLAPPED, Plan, Stage, Timings, process_cpu};
pub use stages::{PreRender, Shading, View, facet_rays, prerender};

/// What a render produces.
pub struct Rendered {
    pub film: Film,
    pub image: RgbaImage,
    pub passes: Vec<(Pass, RgbaImage)>,
    /// Passes stored as 16-bit grey (facet ids), written with `output::write_png16`.
    pub passes16: Vec<(Pass, Gray16)>,
    /// The facet id of every pixel (a single facet when unfaceted); painterly effects read it.
    pub facets: FacetMap,
    /// The facet layout `facets` was rasterised from (what `save_facets` saves).
    pub layout: FacetLayout,
    /// Each facet's centres and re-aim, when the imprecision stage ran (else empty).
    pub aims: Vec<FacetAim>,
    pub timings: Timings,
    pub warnings: Vec<String>,
    /// One line saying which camera was used and where its focal centre is.
    pub camera: String,
}

/// Renders `settings` through the whole pipeline.
pub fn render(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<Rendered> {
    render_hooked(prep, settings, progress, None)
}

/// `render`, calling `after_saliency` on the film once the pre-render and saliency stages are
/// done and before faceting: tests and evaluations use it to supply a known saliency map.
pub fn render_with(
    prep: &Prepared,
    settings: &Settings,
    progress: &Progress,
    after_saliency: &dyn Fn(&Prepared, &mut Film),
) -> Result<Rendered> {
    render_hooked(prep, settings, progress, Some(after_saliency))
}

/// The runner over an empty lane, nothing kept (`Policy::OneOff`). Without a hook, a render
/// whose stages before the re-trace read no colour shades only the pixels the re-trace keeps
/// (`Shading::Deferred`); a hook sees the film fully shaded.
fn render_hooked(
    prep: &Prepared,
    settings: &Settings,
    progress: &Progress,
    after_saliency: Option<&run::AfterSaliency<'_>>,
) -> Result<Rendered> {
    settings.validate()?;
    let params = StageParams::new(settings);
    let mut lane = run::Lane::new(params.trace.width, params.trace.height);
    let policy = cache::Policy::OneOff;
    let frame = run::run(prep, 0, &mut lane, &mut 0, &params, policy, progress, after_saliency)?;
    let (film, facets, layout, aims) = lane.into_products()?;
    Ok(Rendered {
        film,
        image: frame.image,
        passes: frame.passes,
        passes16: frame.passes16,
        facets,
        layout,
        aims,
        timings: frame.timings,
        warnings: frame.warnings,
        camera: frame.camera,
    })
}
