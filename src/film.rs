//! Per-pixel and per-sample buffers of a render: colour plus everything the later stages
//! read (hit triangle, object, distance, normal, barycentrics, saliency). Traced once by the
//! pre-render and reused.

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
    /// Per-pixel saliency in [0, 1] (the saliency map), when computed.
    pub saliency: Option<Vec<f32>>,
}

// SAFETY: plain numbers (u32, f32 and glam's f32 vectors), for which zero bits are a value.
unsafe impl bytemuck::Zeroable for PixelHit {}
// SAFETY: as for `PixelHit`.
unsafe impl bytemuck::Zeroable for SampleHit {}

/// `n` values of zero bits, allocated zeroed: large blocks come from the system as fresh zero
/// pages, so nothing is written here (`vec![Vec4::ZERO; n]` wrote 16 MB on one thread for a
/// million pixels).
fn zeroed_vec<T: bytemuck::Zeroable>(n: usize) -> Vec<T> {
    let layout = match std::alloc::Layout::array::<T>(n) {
        Ok(l) if l.size() > 0 => l,
        // Nothing to allocate, or too much (`collect` then reports the overflow as `vec!` does).
        _ => return (0..n).map(|_| T::zeroed()).collect(),
    };
    // SAFETY: `layout` has a non-zero size; zero bits are a `T` (`Zeroable`); the block holds
    // `n` of them and was allocated by the global allocator with the layout `Vec<T>` uses for
    // capacity `n`.
    unsafe {
        let p = std::alloc::alloc_zeroed(layout) as *mut T;
        if p.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Vec::from_raw_parts(p, n, n)
    }
}

impl Film {
    pub fn new(width: u32, height: u32, spp: u32) -> Film {
        let n = width as usize * height as usize;
        // Filled on every thread: a million pixels' buffers are tens of MB.
        let hits = rayon::iter::repeat_n(PixelHit::MISS, n).collect();
        let samples = rayon::iter::repeat_n(SampleHit::MISS, n * spp as usize).collect();
        Film::with_hits(width, height, spp, hits, samples)
    }

    /// A film for a trace that writes every pixel (the pre-render): its buffers hold zero bits,
    /// not misses, until then, so nothing is written twice (the miss fill of the hits and
    /// samples was 44 MB at a million pixels). A trace cut short (cancelled)
    /// leaves pixels that read as hits on triangle 0: such a film must be thrown away.
    pub fn to_be_traced(width: u32, height: u32, spp: u32) -> Film {
        let n = width as usize * height as usize;
        Film::with_hits(width, height, spp, zeroed_vec(n), zeroed_vec(n * spp as usize))
    }

    /// A film with these hit and sample buffers, its colour black and nothing occluded.
    fn with_hits(width: u32, height: u32, spp: u32, hits: Vec<PixelHit>, samples: Vec<SampleHit>) -> Film {
        let n = width as usize * height as usize;
        Film { width, height, spp, color: zeroed_vec(n), hits, samples, occlusion: vec![0; n], saliency: None }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The zeroed buffers hold what their zero values are: `Film::new`'s colour is the zero
    /// colour it always was, and a film to be traced holds zeroed hits of every size asked.
    #[test]
    fn zeroed_buffers_hold_zero_values() {
        let film = Film::new(7, 5, 3);
        assert!(film.color.len() == 35 && film.color.iter().all(|c| *c == Vec4::ZERO));
        assert!(film.hits.iter().all(|h| *h == PixelHit::MISS) && film.samples.len() == 105);
        assert!(film.samples.iter().all(|s| *s == SampleHit::MISS));
        let zero = PixelHit { tri: 0, object: 0, t: 0.0, normal: Vec3::ZERO, u: 0.0, v: 0.0 };
        for (w, h, spp) in [(0, 0, 1), (1, 1, 1), (640, 480, 4)] {
            let f = Film::to_be_traced(w, h, spp);
            let n = (w * h) as usize;
            assert_eq!((f.color.len(), f.hits.len(), f.samples.len(), f.occlusion.len()), (n, n, n * spp as usize, n));
            assert!(f.color.iter().all(|c| c.to_array().iter().all(|v| v.to_bits() == 0)));
            assert!(f.hits.iter().all(|h| *h == zero && h.t.to_bits() == 0));
            assert!(f.samples.iter().all(|s| *s == SampleHit { tri: 0, u: 0.0, v: 0.0 }));
        }
        assert!(zeroed_vec::<u8>(0).is_empty());
    }
}
