//! One frame whose facets follow a key frame saved beside its layout (`cubist render SCENE
//! --facet-motion follow --facets LAYOUT`, no `--frames`): the route of processes that render
//! a single frame each from a scene posed by someone else (the Blender add-on exports every
//! frame as its own GLB; a farm renders each frame on any machine).
//!
//! Frame N's facets are carried from the key frame in one step (`facets::motion::carry`): the
//! key frame's camera, triangle corners and per-pixel triangle and depth are read from the
//! follow data (`<layout>.follow`, `facets::motion::file`), and this scene's own pre-pass gives
//! each pixel's triangle and barycentrics. Triangles correspond by index: this scene must be
//! the key frame's meshes, posed (same triangle count, same order), or the render fails with
//! a one-line error (`frames::check_key`). With `--save-facets LAYOUT` this scene is the key
//! frame: the layout and its follow data are computed here and saved.
//!
//! The frame is rendered by the frames pipeline (`frames::render_frames`) as a range of one
//! frame whose layout frame is itself, so a frame here depends only on its scene, its settings
//! and the saved layout and follow data: every process and machine renders the same bytes.

use super::Prepared;
use super::frames::{FrameOutput, FramesParams, FramesSummary, render_frames};
use crate::error::{Error, Result};
use crate::facets::motion::file as follow_file;
use crate::progress::Progress;
use crate::settings::{FacetMotion, Faceting, Settings};

/// Whether a still render takes this route: faceted, facets that follow, and a layout file to
/// load (with its follow data) or to save (with the follow data made here).
pub fn follows_saved_key(settings: &Settings) -> bool {
    settings.facet_motion == FacetMotion::Follow
        && settings.faceting != Faceting::None
        && (settings.facets.is_some() || settings.save_facets.is_some())
}

/// Renders the loaded scene as one frame carried from the saved key frame (or, with
/// `save_facets`, as the key frame itself, saving the layout and its follow data).
pub fn render_followed_frame(
    prep: &Prepared,
    settings: &Settings,
    progress: &Progress,
) -> Result<(FrameOutput, FramesSummary)> {
    // (A missing layout is the layout loader's error.)
    if let (Some(layout), None) = (&settings.facets, &settings.save_facets) {
        let data = follow_file::path_for(layout);
        if layout.is_file() && !data.is_file() {
            return Err(Error::setting(
                "facets",
                format!(
                    "facet layout {} has no follow data beside it ({}): save the layout with --facet-motion follow, \
                     or render with --facet-motion static",
                    layout.display(),
                    data.display()
                ),
            ));
        }
    }
    let frames = FramesParams { fps: 1.0, ..FramesParams::new(1, 1) };
    let mut frame = None;
    let summary = render_frames(prep, settings, &frames, progress, &mut |out| {
        frame = Some(out);
        Ok(())
    })?;
    let frame = frame.ok_or_else(|| Error::setting("frames", "the frame was not rendered"))?;
    Ok((frame, summary))
}
