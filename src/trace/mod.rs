//! The trace loop: stratified, seeded samples per pixel, rayon over bands of square tiles (or
//! over chunks of a pixel subset for the re-trace of moved facets), writing colour and every
//! hit buffer; and the adaptive anti-aliasing that gives more samples only to pixels whose
//! neighbours disagree. Each sample's randomness is a hash of (seed, pixel, sample), so images
//! are identical for any thread count.

use glam::{DVec2, Vec3, Vec4};
use rayon::prelude::*;

use crate::accel::{Accel, Hit};
use crate::camera::CameraRay;
use crate::film::{Film, NO_HIT, PixelHit, SampleHit};
use crate::progress::Progress;
use crate::scene::World;
use crate::scene::srgb::Srgb8;
use crate::shading::{LightRig, Occlusion, SurfacePoint, shade_with, shading_normal, surface};
use crate::util::rng::{splitmix64, unit_f64};

mod antialias;
mod bands;
mod run_on;
pub(crate) use run_on::run_on;
mod sampler;
mod shadows;
mod tracer;

use bands::*;
use shadows::*;
use tracer::*;

pub use antialias::{antialias_known, pixels_to_refine};
pub use sampler::{centre_rook_offset, sample_offset};
pub(crate) use shadows::coarse_grid_around;

/// The screen point of pixel (x, y) at sub-pixel `offset` (defined beside the cameras, whose
/// `centre_rays` tabulate the pixel centres' points).
pub use crate::camera::screen_point;

/// What a trace needs from the settings: the film's size and samples, the seed, the lights'
/// options and the background.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceParams {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the final image (stratified, see `sample_offset`). The pre-render
    /// the facets and saliency read traces one, at each pixel's centre; the anti-aliasing
    /// stage gives `spp` to every pixel (`aa_threshold` 0) or to those that need them.
    pub spp: u32,
    /// Adaptive anti-aliasing: a pixel gets `spp` samples only where it differs from a
    /// neighbour of its facet by more than this (sRGB, 0..1, any channel) or shows another
    /// object or the background; elsewhere it keeps its centre sample. 0: every pixel.
    pub aa_threshold: f32,
    pub seed: u64,
    /// Cast one shadow ray per light per hit.
    pub shadows: bool,
    /// Multiplier on the automatically exposed lights.
    pub exposure: f32,
    /// Linear RGB of rays that hit nothing.
    pub background: [f32; 3],
}

/// Everything a trace needs besides the rays.
pub struct Tracer<'a> {
    pub world: &'a World,
    pub accel: &'a Accel,
    /// None: record hits only (face counting), no shading.
    pub rig: Option<&'a LightRig>,
    pub background: Vec3,
    pub seed: u64,
}

/// A source of rays: (pixel index, screen point) -> ray.
pub type Rays<'r> = dyn Fn(usize, DVec2) -> CameraRay + Sync + 'r;

/// Centre hits already found (`imprecision::cues::CentreHits`): pixel index -> Some(closest
/// hit of its one-sample centre ray, None on a miss), or None when not known.
pub type KnownHits<'r> = dyn Fn(usize) -> Option<Option<Hit>> + Sync + 'r;

/// Pixels per parallel work item of the subset traces.
const CHUNK: usize = 256;

#[cfg(test)]
mod tests;
#[cfg(test)]
use antialias::*;
