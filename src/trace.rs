//! The trace loop: stratified, seeded samples per pixel, rayon over rows (or over chunks of a
//! pixel subset for the re-trace of moved facets), writing colour and every hit buffer.
//! Each sample's randomness is a hash of (seed, pixel, sample), so images are identical for
//! any thread count.

use glam::{DVec2, Vec3, Vec4};
use rayon::prelude::*;

use crate::accel::Accel;
use crate::camera::CameraRay;
use crate::film::{Film, NO_HIT, PixelHit, SampleHit};
use crate::progress::Progress;
use crate::scene::World;
use crate::shading::{LightRig, shade, surface};
use crate::util::rng::{splitmix64, unit_f64};

/// Strata of `spp` samples: a `nx x ny` grid with nx * ny = spp, as square as spp allows.
fn strata(spp: u32) -> (u32, u32) {
    let mut ny = (spp as f64).sqrt() as u32;
    while ny > 1 && !spp.is_multiple_of(ny) {
        ny -= 1;
    }
    (spp / ny.max(1), ny.max(1))
}

/// Offset of sample `s` within pixel `pixel`, in [0, 1)^2. One sample: the pixel centre.
/// Otherwise jittered stratified: one sample per cell of the `strata` grid.
#[inline]
pub fn sample_offset(seed: u64, pixel: u64, s: u32, spp: u32) -> DVec2 {
    if spp == 1 {
        return DVec2::splat(0.5);
    }
    let (nx, ny) = strata(spp);
    let h = splitmix64(seed ^ splitmix64(pixel.wrapping_mul(0x1_0000_0001).wrapping_add(s as u64)));
    let jx = unit_f64(h);
    let jy = unit_f64(splitmix64(h));
    DVec2::new(((s % nx) as f64 + jx) / nx as f64, ((s / nx) as f64 + jy) / ny as f64)
}

/// The screen point of pixel (x, y) at sub-pixel `offset` (row 0 is the top).
#[inline]
pub fn screen_point(x: u32, y: u32, offset: DVec2, width: u32, height: u32) -> DVec2 {
    DVec2::new((x as f64 + offset.x) / width as f64 - 0.5, 0.5 - (y as f64 + offset.y) / height as f64)
}

/// One chunk of a pixel-subset re-trace: each pixel's colour and hit, then its samples' hits.
type SubsetChunk = (Vec<(Vec4, PixelHit)>, Vec<SampleHit>);

/// What a trace needs from the settings: the film's size and samples, the seed, the lights'
/// options and the background.
#[derive(Clone, Debug, PartialEq)]
pub struct TraceParams {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (stratified, see `sample_offset`).
    pub spp: u32,
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

impl Tracer<'_> {
    fn trace_pixel(
        &self,
        i: usize,
        width: u32,
        height: u32,
        samples: &mut [SampleHit],
        rays: &Rays,
    ) -> (Vec4, PixelHit) {
        let spp = samples.len() as u32;
        let (x, y) = (i as u32 % width, i as u32 / width);
        let mut color = Vec3::ZERO;
        let mut covered = 0u32;
        let mut best = (f64::INFINITY, PixelHit::MISS);
        for s in 0..spp {
            let off = sample_offset(self.seed, i as u64, s, spp);
            let ray = rays(i, screen_point(x, y, off, width, height));
            let hit = self.accel.closest(ray.origin, ray.dir, 0.0, f32::INFINITY);
            let centre_dist = (off - DVec2::splat(0.5)).length_squared();
            match hit {
                Some(h) => {
                    samples[s as usize] = SampleHit { tri: h.tri, u: h.u, v: h.v };
                    covered += 1;
                    // The surface is needed to shade, or for the pixel's representative hit.
                    let nearest = centre_dist < best.0;
                    if self.rig.is_some() || nearest {
                        let sp = surface(self.world, &h, ray.origin, ray.dir);
                        if let Some(rig) = self.rig {
                            color += shade(self.accel, rig, &sp, ray.dir);
                        }
                        if nearest {
                            let hit =
                                PixelHit { tri: h.tri, object: h.object, t: h.t, normal: sp.normal, u: h.u, v: h.v };
                            best = (centre_dist, hit);
                        }
                    }
                }
                None => {
                    samples[s as usize] = SampleHit::MISS;
                    color += self.background;
                    if centre_dist < best.0 {
                        best = (centre_dist, PixelHit::MISS);
                    }
                }
            }
        }
        let hit = best.1;
        debug_assert!(hit.tri == NO_HIT || hit.object != NO_HIT);
        ((color / spp as f32).extend(covered as f32 / spp as f32), hit)
    }

    /// Traces `pixels` (all when None) of `frame` with `rays`, overwriting their colour, hit
    /// and sample buffers.
    pub fn render(&self, film: &mut Film, rays: &Rays, pixels: Option<&[u32]>, progress: &Progress) {
        let (w, h, spp) = (film.width, film.height, film.spp as usize);
        match pixels {
            None => {
                let wu = w as usize;
                film.color
                    .par_chunks_mut(wu)
                    .zip(film.hits.par_chunks_mut(wu))
                    .zip(film.samples.par_chunks_mut(wu * spp))
                    .enumerate()
                    .for_each(|(y, ((c, hrow), srow))| {
                        // Cancelled (cubist serve): the remaining rows are skipped; the caller
                        // checks `progress.check()` and throws the film away.
                        if progress.cancelled() {
                            return;
                        }
                        for x in 0..wu {
                            let i = y * wu + x;
                            let (col, hit) = self.trace_pixel(i, w, h, &mut srow[x * spp..(x + 1) * spp], rays);
                            c[x] = col;
                            hrow[x] = hit;
                        }
                        progress.add(wu as u64);
                    });
            }
            Some(list) => {
                let chunks: Vec<SubsetChunk> = list
                    .par_chunks(256)
                    .map(|chunk| {
                        let mut samples = vec![SampleHit::MISS; chunk.len() * spp];
                        if progress.cancelled() {
                            let skipped = vec![(Vec4::ZERO, PixelHit::MISS); chunk.len()];
                            return (skipped, samples);
                        }
                        let out = chunk
                            .iter()
                            .enumerate()
                            .map(|(k, &i)| {
                                self.trace_pixel(i as usize, w, h, &mut samples[k * spp..(k + 1) * spp], rays)
                            })
                            .collect();
                        progress.add(chunk.len() as u64);
                        (out, samples)
                    })
                    .collect();
                for (chunk, (out, samples)) in list.chunks(256).zip(chunks) {
                    for (k, &i) in chunk.iter().enumerate() {
                        let i = i as usize;
                        film.color[i] = out[k].0;
                        film.hits[i] = out[k].1;
                        film.samples[i * spp..(i + 1) * spp].copy_from_slice(&samples[k * spp..(k + 1) * spp]);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strata_are_as_square_as_possible() {
        assert_eq!(strata(1), (1, 1));
        assert_eq!(strata(4), (2, 2));
        assert_eq!(strata(8), (4, 2));
        assert_eq!(strata(7), (7, 1));
        assert_eq!(strata(16), (4, 4));
    }

    #[test]
    fn samples_are_stratified_and_in_the_pixel() {
        for spp in [2u32, 4, 6, 9, 16] {
            let (nx, ny) = strata(spp);
            let mut cells = vec![0; spp as usize];
            for s in 0..spp {
                let o = sample_offset(7, 123, s, spp);
                assert!((0.0..1.0).contains(&o.x) && (0.0..1.0).contains(&o.y));
                let cell = (o.y * ny as f64) as u32 * nx + (o.x * nx as f64) as u32;
                cells[cell as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "spp {spp}: {cells:?}");
        }
    }

    #[test]
    fn single_sample_is_the_pixel_centre() {
        assert_eq!(sample_offset(1, 2, 0, 1), DVec2::splat(0.5));
        let p = screen_point(0, 0, DVec2::splat(0.5), 2, 2);
        assert_eq!(p, DVec2::new(-0.25, 0.25));
    }

    #[test]
    fn seeds_change_the_jitter() {
        assert_ne!(sample_offset(1, 5, 0, 4), sample_offset(2, 5, 0, 4));
        assert_eq!(sample_offset(1, 5, 0, 4), sample_offset(1, 5, 0, 4));
    }
}
