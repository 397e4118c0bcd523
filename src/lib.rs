//! cubist: renders 3D scenes in the manner of Analytical Cubism, after Arpa, Bulbul, Capin and
//! Ozguc, "Perceptual 3D rendering based on principles of analytical cubism" (2012).
//!
//! Data flows one way: `cli` (flags) -> `settings` (validated) -> `pipeline` (each stage's
//! parameters, the stages in order) -> the stages: `framing` (placing the cameras), `camera`
//! (cubist cameras) and `trace` (the trace into `film` buffers, `shading`), `saliency` (mesh saliency), `facets` (layouts),
//! `imprecision` (per-facet re-aim), `paint` (painterly effects), `output` (images, files),
//! `eval` (visible faces). Below them: `scene` (glTF loading), `accel` (BVH), `distance`,
//! `util`, `progress`, `error`. `serve` is the other front: a long-running renderer keeping a
//! `pipeline::Session`. ARCHITECTURE.md draws the map.

pub mod accel;
pub mod camera;
pub mod cli;
pub mod distance;
pub mod error;
pub mod eval;
pub mod facets;
pub mod film;
pub mod framing;
pub mod imprecision;
pub mod look;
pub mod motion;
pub mod output;
pub mod paint;
pub mod pipeline;
pub mod progress;
pub mod saliency;
pub mod scene;
pub mod serve;
pub mod settings;
pub mod shading;
pub mod strokes;
pub mod trace;
pub mod util;

pub use error::{Error, Result};
pub use pipeline::{Prepared, Rendered, render};
pub use settings::Settings;
