//! `cubist saliency`: the pre-render's hits (no shading: the map needs none) and the saliency
//! map read off them.

use image::RgbaImage;

use super::stages::saliency_stage;
use super::{Prepared, Shading, StageParams, Timings, prerender};
use crate::error::Result;
use crate::film::Film;
use crate::progress::Progress;
use crate::saliency::{MeshSaliency, saliency_image};
use crate::settings::Settings;

/// What `cubist saliency` produces.
pub struct SaliencyRender {
    /// The pre-render, with its saliency map.
    pub film: Film,
    /// Per-vertex saliency of the meshes in view.
    pub mesh: MeshSaliency,
    /// The map as a grey image (white = most salient).
    pub image: RgbaImage,
    pub timings: Timings,
    pub warnings: Vec<String>,
    /// One line saying which camera was used.
    pub camera: String,
}

/// The saliency map of the view `settings` frame.
pub fn saliency_map(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<SaliencyRender> {
    settings.validate()?;
    let params = StageParams::new(settings);
    let mut timings = Timings::default();
    let pre = prerender(prep, &params.framing, &params.trace, Shading::HitsOnly, progress, &mut timings)?;
    let mut film = pre.film;
    let (mesh, map) = saliency_stage(prep, &film, &params.saliency, progress, &mut timings)?;
    let image = saliency_image(&map, film.width, film.height);
    film.saliency = Some(map);
    Ok(SaliencyRender { film, mesh, image, timings, warnings: pre.warnings, camera: pre.view.describe_camera(prep) })
}
