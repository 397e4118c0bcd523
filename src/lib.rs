//! cubist: renders 3D scenes in the manner of Analytical Cubism, after Arpa, Bulbul, Capin and
//! Ozguc, "Perceptual 3D rendering based on principles of analytical cubism" (2012).
//!
//! The pipeline (SPEC Fig. 4.1) is one module per stage: `scene` (glTF loading) ->
//! `accel` (BVH) -> `camera` (cubist cameras) -> `render` (the trace, into `frame` buffers)
//! -> `shading`; `facets` (layouts) -> `imprecision` (per-facet re-aim) -> `paint` (painterly
//! effects); `eval` counts visible faces; `pipeline` runs the stages the settings need.

pub mod accel;
pub mod backdrop;
pub mod camera;
pub mod cli;
pub mod distance;
pub mod error;
pub mod eval;
pub mod facets;
pub mod frame;
pub mod imprecision;
pub mod look;
pub mod output;
pub mod paint;
pub mod pipeline;
pub mod progress;
pub mod render;
pub mod saliency;
pub mod scene;
pub mod settings;
pub mod shading;

pub use error::{Error, Result};
pub use pipeline::{Prepared, Rendered, render};
pub use settings::Settings;
