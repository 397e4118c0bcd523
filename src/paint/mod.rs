//! Painterly effects (SPEC "Painterly effects", thesis 4.4): a fixed chain of post effects on
//! the rendered colour, reading the facet ids and hit buffers, each its own module behind the
//! `Effect` trait and left out of the chain when its setting is off.
//!
//! Order (fixed): chiaroscuro (relights the shading, so it must see the unmodified render) ->
//! silhouettes -> facet borders drawn symmetric (eq 4.8) -> gradient overlays (the geometric
//! darkenings and lightenings) -> colour transfer / palette (maps the final luminance onto the
//! painter's colours, so borders and gradients come out in palette colours too) ->
//! quantisation (so the paint has at most K colours) -> brushwork (strokes of the palette's
//! colours, drawn towards their plane's mean) -> per-plane light (the ramp across each plane,
//! after the palette: the palette ranks luminance, and ramps spread over a large backdrop
//! would push a small subject's values to the ends of the ramp; after the strokes, which would
//! otherwise flatten the ramp with their plane's mean) -> the subject's inner contours drawn
//! (after the paint and the light, so the line lies on both) -> facet borders drawn as passage
//! (after the strokes and the ramps, so a lost edge melts the two planes' paint and light
//! together and the line lies on the darker side as lit) -> value range (a fixed curve
//! deepening the darks and raising the lights, on the finished paint) -> canvas grain (last:
//! the weave shows through the paint).
//!
//! Background and alpha. An opaque image's background is part of the canvas: every effect
//! paints it (borders cross it, the palette colours it). A transparent image has no background
//! to paint: colour effects touch only what was rendered (coverage > 0), and the darkening
//! effects (borders, silhouettes) become black with alpha, so compositing the PNG over the
//! background colour gives the opaque image wherever only darkening happened. The frame's
//! colour stays in the form `output::encode` expects: colour = foreground premultiplied +
//! (1 - alpha) x background.

pub mod border_profile;
pub mod borders;
pub mod brushwork;
pub mod canvas;
pub mod chiaroscuro;
pub mod context;
pub mod contours;
pub mod edge_smoothing;
pub mod effect;
pub mod gradients;
pub mod inputs;
pub mod measure;
pub mod noise;
pub mod painter;
pub mod palette;
pub mod params;
pub mod passage;
pub mod plane_light;
pub mod planes;
pub mod quantise;
pub mod ranks;
pub mod region_means;
pub mod sequence;
pub mod silhouettes;
pub mod values;

pub use context::{Canvas, Coverage, Lighting, PaintContext, darken, darken_background};
pub use effect::{Effect, EffectParams, Keyed};
pub use inputs::{Edges, OPEN_MIN_SHARE, PaintInputs};
pub use painter::{Painter, Resume, apply_chain};
pub use palette::{PLANE_HUE_STRENGTH, Palette};
pub use params::PaintParams;
pub use passage::BorderStyle;
pub use ranks::{KEY_LEVELS, LuminanceKeys, UNPAINTED, luminance};
pub use sequence::{Held, Sequence};

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_passage;
#[cfg(test)]
mod tests_plane;
