//! Per-pixel and per-sample buffers of a render: colour plus everything the later stages
//! read (hit triangle, object, distance, normal, barycentrics, saliency). Traced once by the
//! pre-render and reused (SPEC "Pipeline" step 1).

use glam::{Vec3, Vec4};
use rayon::prelude::*;

/// Triangle id of a sample or pixel that hit nothing.
pub const NO_HIT: u32 = u32::MAX;

/// One primary sample's hit: enough to interpolate any vertex attribute (saliency) later
/// and to count visible faces. 12 bytes, kept for every sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleHit {
    /// World triangle id, or `NO_HIT`.
    pub tri: u32,
    /// Barycentrics: the point is (1 - u - v) p0 + u p1 + v p2.
    pub u: f32,
    pub v: f32,
}

impl SampleHit {
    pub const MISS: SampleHit = SampleHit { tri: NO_HIT, u: 0.0, v: 0.0 };
    pub fn is_hit(&self) -> bool {
        self.tri != NO_HIT
    }
}

/// A pixel's representative hit: that of its sample nearest the pixel centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelHit {
    pub tri: u32,
    /// Index into `World::objects`, or `NO_HIT`.
    pub object: u32,
    /// Distance along the ray, render units (infinite on a miss).
    pub t: f32,
    /// Unit shading normal facing the ray (zero on a miss).
    pub normal: Vec3,
    pub u: f32,
    pub v: f32,
}

impl PixelHit {
    pub const MISS: PixelHit =
        PixelHit { tri: NO_HIT, object: NO_HIT, t: f32::INFINITY, normal: Vec3::ZERO, u: 0.0, v: 0.0 };
    pub fn is_hit(&self) -> bool {
        self.tri != NO_HIT
    }
}

/// A rendered image and its buffers. Pixel index = y * width + x, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Linear RGB averaged over samples (misses contribute the background colour) and, in
    /// alpha, the fraction of samples that hit geometry.
    pub color: Vec<Vec4>,
    pub hits: Vec<PixelHit>,
    /// Every sample's hit, `spp` per pixel, pixel-major.
    pub samples: Vec<SampleHit>,
    /// Lights the pixel's representative sample found blocked, one bit per light (the first
    /// 8; `shading::Occlusion`): where neighbours agree, anti-aliasing casts no shadow ray.
    pub occlusion: Vec<u8>,
    /// Per-pixel saliency in [0, 1] (SPEC "Mesh saliency", the saliency map), when computed.
    pub saliency: Option<Vec<f32>>,
}

impl Film {
    pub fn new(width: u32, height: u32, spp: u32) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            spp,
            color: vec![Vec4::ZERO; n],
            // Filled on every thread: a million pixels' buffers are tens of MB (issue 16).
            hits: rayon::iter::repeat_n(PixelHit::MISS, n).collect(),
            samples: rayon::iter::repeat_n(SampleHit::MISS, n * spp as usize).collect(),
            occlusion: vec![0; n],
            saliency: None,
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The samples of pixel `i`.
    pub fn pixel_samples(&self, i: usize) -> &[SampleHit] {
        let s = self.spp as usize;
        &self.samples[i * s..(i + 1) * s]
    }
}
