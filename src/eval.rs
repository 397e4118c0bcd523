//! Visible-face counting: the number of distinct triangles hit by primary rays, the measure
//! of the thesis's Table 4.1 (SPEC "Evaluation").

use serde::Serialize;

use crate::camera::frame_camera;
use crate::error::Result;
use crate::frame::Frame;
use crate::pipeline::Prepared;
use crate::progress::Progress;
use crate::render::Tracer;
use crate::settings::Settings;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct VisibleFaces {
    /// Distinct triangles hit by at least one primary sample.
    pub visible: usize,
    /// Triangles in the scene (degenerate ones included, as in a mesh's face count).
    pub total: usize,
}

impl VisibleFaces {
    pub fn percent(&self) -> f64 {
        if self.total == 0 { 0.0 } else { 100.0 * self.visible as f64 / self.total as f64 }
    }
}

/// Counts the distinct triangles among every sample of a traced frame.
pub fn count_visible(frame: &Frame, total: usize) -> VisibleFaces {
    let mut seen = vec![false; total];
    let mut visible = 0;
    for s in &frame.samples {
        if let Some(slot) = seen.get_mut(s.tri as usize) {
            if !*slot {
                *slot = true;
                visible += 1;
            }
        }
    }
    VisibleFaces { visible, total }
}

/// Traces the primary rays of `settings`' camera (no shading) and counts visible faces.
pub fn visible_faces(prep: &Prepared, settings: &Settings) -> Result<VisibleFaces> {
    let framed = frame_camera(settings, &prep.world)?;
    let mut frame = Frame::new(settings.width, settings.height, settings.spp);
    let tracer =
        Tracer { world: &prep.world, accel: &prep.accel, rig: None, background: glam::Vec3::ZERO, seed: settings.seed };
    tracer.render(&mut frame, &|_, p| framed.camera.ray(p), None, &Progress::silent());
    Ok(count_visible(&frame, prep.world.triangle_count()))
}
