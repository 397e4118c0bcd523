//! The look report's renders (`crate::look`): render with the settings, keep the pre-render,
//! and hand both with the layout, the aims and the mesh saliency to `look::measure`.

use std::sync::Mutex;
use std::time::Instant;

use image::RgbaImage;

use super::{Prepared, StageParams, render_with};
use crate::error::Result;
use crate::facets::{self, FacetLayout};
use crate::film::Film;
use crate::look::{self, LookRow};
use crate::progress::Progress;
use crate::settings::Settings;

/// A measured render: its row and its picture.
pub struct Look {
    pub row: LookRow,
    pub image: RgbaImage,
}

/// Renders `prep` with `settings` and measures the result (`look::measure`).
pub fn look(prep: &Prepared, settings: &Settings, scene_name: &str) -> Result<Look> {
    let params = StageParams::new(settings);
    let pre: Mutex<Option<Film>> = Mutex::new(None);
    let t = Instant::now();
    let rendered = render_with(prep, settings, &Progress::silent(), &|_, film| {
        *pre.lock().unwrap_or_else(|e| e.into_inner()) = Some(film.clone());
    })?;
    let time_ms = t.elapsed().as_secs_f64() * 1e3;
    let pre = pre.into_inner().unwrap_or_else(|e| e.into_inner()).unwrap_or_else(|| rendered.film.clone());
    // The layout again from the same pre-render (deterministic), for its polygon coverage.
    let layout =
        if params.facets.faceted() { facets::layout_for(&params.facets, &pre)? } else { FacetLayout::single() };
    let moved: Vec<bool> = if rendered.aims.is_empty() {
        vec![false; rendered.facets.facet_count as usize]
    } else {
        rendered.aims.iter().map(|a| a.moved()).collect()
    };
    let saliency = crate::saliency::for_film(&prep.scene, &prep.world, &prep.saliency, &pre, &params.saliency)?;
    let saliency_map = crate::saliency::saliency_map(&prep.world, &saliency, &pre, &params.saliency);
    let stretch = if params.facets.faceted() || params.framing.kind != crate::camera::CameraKind::Perspective {
        look::legibility::stretch(&params.framing, &prep.world, &prep.accel)?
    } else {
        Some(1.0)
    };
    let row = look::measure(&look::Render {
        scene_name,
        camera: &rendered.camera,
        width: settings.width,
        height: settings.height,
        pre: &pre,
        fin: &rendered.film,
        image: &rendered.image,
        layout: &layout,
        map: &rendered.facets,
        moved: &moved,
        scene: &prep.scene,
        world: &prep.world,
        vertex_saliency: &saliency.per_mesh,
        parts: params.saliency.reads_parts(),
        saliency_map: &saliency_map,
        stretch,
        time_ms,
    });
    Ok(Look { row, image: rendered.image })
}
