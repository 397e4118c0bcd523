//! The render's stages (thesis Fig. 4.1), each a function of plain values returning its output,
//! with the key of exactly what it reads (which `cache::Run` keeps its output by):
//!
//! | stage | inputs | output |
//! |---|---|---|
//! | `prerender` | scene (`Prepared`), `FramingParams`, `TraceParams` | `PreRender`: film (colour, hits, samples), camera, lights |
//! | `saliency` | scene, pre-render film, `SaliencyParams` | mesh saliency, per-pixel saliency map |
//! | `layout` | pre-render film (+ map), `FacetParams` | `FacetLayout`, its `FacetMap` |
//! | `aims` | camera, facet map, saliency map and coverage, `AimParams` | one `FacetAim` per facet |
//! | `retrace` | camera, facet map, aims, tracer | film with moved facets traced again |
//! | `antialias` | camera, facet map, aims, film, tracer | film colour with `spp` samples where needed |
//! | `paint` | film, facet map, lights, `Painter` | film colour painted |
//! | `encode` | film, facets, aims, passes | image and pass images |
//!
//! Stages that work on the film take a policy-valued argument (`Retracing`, `Refining`,
//! `Painting`): in place for a one-off render or an animation frame, or kept apart from the
//! film for a session that reuses them.

pub mod aims;
pub mod antialias;
pub mod encode;
pub mod layout;
pub mod paint;
pub mod prerender;
pub mod retrace;
pub mod saliency;

pub use aims::{aim_context, aims_stage};
pub use antialias::{Refining, antialias_stage};
pub use encode::{Encoded, encode_stage};
pub use layout::layout_stage;
pub use paint::{Painting, paint_stage};
pub use prerender::{PreRender, Shading, View, prerender};
pub use retrace::{Retracing, facet_rays, moved_pixels, retrace_stage, shade_stage};
pub use saliency::saliency_stage;
