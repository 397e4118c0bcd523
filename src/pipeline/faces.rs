//! `cubist faces`: the pre-render's hits through a camera (no shading) and the distinct
//! triangles among them (the thesis's Table 4.1 measure, `eval`).

use super::{Prepared, Shading, StageParams, Timings, prerender};
use crate::error::Result;
use crate::eval::{CameraParams, Evaluation, VisibleFaces, visible_ids};
use crate::progress::Progress;
use crate::settings::Settings;

/// Traces the primary rays of `settings`' camera (no shading) and counts visible faces.
pub fn evaluate(prep: &Prepared, settings: &Settings) -> Result<Evaluation> {
    settings.validate()?;
    let params = StageParams::new(settings);
    let pre = prerender(
        prep,
        &params.framing,
        &params.trace,
        Shading::HitsOnly,
        &Progress::silent(),
        &mut Timings::default(),
    )?;
    let total = prep.world.triangle_count();
    let ids = visible_ids(&pre.film, total);
    Ok(Evaluation {
        faces: VisibleFaces { visible: ids.len(), total },
        camera: CameraParams::new(&pre.view.framed, &prep.world, settings.width, settings.height),
        ids,
    })
}

/// The visible-face count of `settings`' camera.
pub fn visible_faces(prep: &Prepared, settings: &Settings) -> Result<VisibleFaces> {
    Ok(evaluate(prep, settings)?.faces)
}
