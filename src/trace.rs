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

/// The columns' rows of `centre_rook_offset`'s 3 rooks: the permutations of 0..3 that leave
/// the middle cell, where the centre sample is, empty.
const CENTRE_ROOKS: [[u32; 3]; 4] = [[0, 2, 1], [1, 0, 2], [2, 0, 1], [1, 2, 0]];

/// Offset of new sample `s` (0..3) of pixel `pixel` when anti-aliasing at 4 samples takes the
/// pixel's centre sample, already traced, as its fourth (issue 16): 3 rooks on a 3 x 3 grid
/// (one per column and row, none in the middle cell, which holds the centre), jittered in
/// their cells, the permutation picked by a hash of (seed, pixel). With equal weights, the
/// mean squared error of a pixel's coverage by a random straight edge is below that of 4
/// jittered 2 x 2 strata (0.017 against 0.020, simulated; the centre instead of one of the 2
/// x 2 samples: 0.026).
#[inline]
pub fn centre_rook_offset(seed: u64, pixel: u64, s: u32) -> DVec2 {
    let rows = CENTRE_ROOKS[(splitmix64(seed ^ splitmix64(pixel ^ 0xC3A5_C85C_97CB_3127)) % 4) as usize];
    let h = splitmix64(seed ^ splitmix64(pixel.wrapping_mul(0x1_0000_0001).wrapping_add(s as u64)));
    let (jx, jy) = (unit_f64(h), unit_f64(splitmix64(h)));
    DVec2::new((s as f64 + jx) / 3.0, (rows[s as usize] as f64 + jy) / 3.0)
}

/// The screen point of pixel (x, y) at sub-pixel `offset` (defined beside the cameras, whose
/// `centre_rays` tabulate the pixel centres' points).
pub use crate::camera::screen_point;

/// One chunk of a pixel-subset re-trace: each pixel's colour, hit and lights blocked, then its
/// samples' hits.
type SubsetChunk = (Vec<(Vec4, PixelHit, u8)>, Vec<SampleHit>);

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

/// Side in pixels of the square tiles `Tracer::render_rows` traces one after another (bands of
/// `TILE` rows in parallel). Why: neighbouring rays walk mostly the same BVH nodes and
/// triangles, so a tile's rays likely find them still in cache (the likely reason, not
/// measured; the other stages' sparser pixel lists were slower in tiles). Each pixel is traced
/// as before, only in another order (same bits). Measured on the 1M-triangle scene at
/// 1000 x 1000 (issue 16): the pre-render 0.93x CPU.
const TILE: usize = 16;

/// The picked pixels of one row of a tile (band offsets, ascending), and the 2 x 2 packets
/// two such rows make (`Tracer::render_rows`).
#[derive(Clone, Copy)]
struct TileRow {
    j: [usize; TILE],
    len: usize,
}

impl TileRow {
    /// Rays per packet (`Accel::closest4`).
    const PACKET: usize = 4;
    const EMPTY: TileRow = TileRow { j: [0; TILE], len: 0 };

    /// The offsets of `row` that `pick` keeps.
    fn picked(row: std::ops::Range<usize>, pick: impl Fn(usize) -> bool) -> TileRow {
        let mut out = TileRow::EMPTY;
        for j in row.filter(|&j| pick(j)) {
            out.j[out.len] = j;
            out.len += 1;
        }
        out
    }

    /// Packets of up to four: two pixels of `self` and the two below them in `below`, in
    /// turn; where one row runs out, up to four of the other's.
    fn blocks_with(self, below: &TileRow) -> impl Iterator<Item = TileRow> + '_ {
        let (mut a, mut b) = (0, 0);
        std::iter::from_fn(move || {
            let mut p = TileRow::EMPTY;
            let take_a = if b < below.len { 2 } else { TileRow::PACKET };
            while p.len < take_a && a < self.len {
                p.j[p.len] = self.j[a];
                (p.len, a) = (p.len + 1, a + 1);
            }
            while p.len < TileRow::PACKET && b < below.len {
                p.j[p.len] = below.j[b];
                (p.len, b) = (p.len + 1, b + 1);
            }
            (p.len > 0).then_some(p)
        })
    }
}

/// A packet of the rays `ray(l)` for l < n (1 to 4), the last one repeated in the lanes left
/// (each ray made once: a camera ray costs about as much as a few box tests).
#[inline]
fn packet_of(n: usize, mut ray: impl FnMut(usize) -> CameraRay) -> [CameraRay; TileRow::PACKET] {
    debug_assert!((1..=TileRow::PACKET).contains(&n));
    let mut out = [ray(0); TileRow::PACKET];
    for l in 1..TileRow::PACKET {
        out[l] = if l < n { ray(l) } else { out[l - 1] };
    }
    out
}

/// Rows per parallel work item of `Tracer::render_subset_in_place` (4000 pixels at 1000 wide:
/// small enough that bands full of moved pixels and empty ones balance across threads).
const BAND_ROWS: usize = 4;

/// Pixels `Tracer::shade_traced` traces before writing them (64 work items): its results
/// held at once stay about 4 MB whatever the image.
const SHADE_BATCH: usize = 64 * CHUNK;

impl Tracer<'_> {
    /// One sample's radiance (the background on a miss), its hit and the lights it found
    /// blocked.
    #[inline]
    fn sample(&self, ray: &CameraRay, known: Known) -> (Vec3, Option<(Hit, Option<SurfacePoint>)>, u8) {
        self.sample_hit(ray, known, self.accel.closest(ray.origin, ray.dir, 0.0, f32::INFINITY))
    }

    /// `sample` with `ray`'s closest hit `hit` already found.
    #[inline]
    fn sample_hit(
        &self,
        ray: &CameraRay,
        known: Known,
        hit: Option<Hit>,
    ) -> (Vec3, Option<(Hit, Option<SurfacePoint>)>, u8) {
        let Some(h) = hit else {
            return (self.background, None, 0);
        };
        match self.rig {
            Some(rig) => {
                let sp = surface(self.world, &h, ray.origin, ray.dir);
                let (c, blocked) = shade_with(self.accel, rig, &sp, ray.dir, known.for_hit(&h));
                (c, Some((h, Some(sp))), blocked)
            }
            None => (Vec3::ZERO, Some((h, None)), 0),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn trace_pixel(
        &self,
        i: usize,
        width: u32,
        height: u32,
        samples: &mut [SampleHit],
        rays: &Rays,
        known: Known,
        centre: Option<&KnownHits>,
        traced: Option<(&CameraRay, Option<Hit>)>,
    ) -> (Vec4, PixelHit, u8) {
        let spp = samples.len() as u32;
        // One sample is the centre ray: it and its closest hit may be known already (`traced`,
        // at one sample per pixel), or its hit alone (`centre`).
        let centre = match traced {
            Some((_, hit)) => Some(hit),
            None if spp == 1 => centre.and_then(|c| c(i)),
            None => None,
        };
        if let Some(None) = centre {
            // A known miss needs no ray: the background, as the loop below gives it.
            samples[0] = SampleHit::MISS;
            let color = Vec3::ZERO + self.background;
            return ((color / 1.0).extend(0.0 / 1.0), PixelHit::MISS, 0);
        }
        let (x, y) = (i as u32 % width, i as u32 / width);
        let mut color = Vec3::ZERO;
        let mut covered = 0u32;
        let mut best = (f64::INFINITY, PixelHit::MISS, 0u8);
        for s in 0..spp {
            let off = sample_offset(self.seed, i as u64, s, spp);
            let ray = match traced {
                Some((ray, _)) => *ray,
                None => rays(i, screen_point(x, y, off, width, height)),
            };
            let centre_dist = (off - DVec2::splat(0.5)).length_squared();
            let nearest = centre_dist < best.0;
            let (c, hit, blocked) = match centre {
                Some(h) => self.sample_hit(&ray, known, h),
                None => self.sample(&ray, known),
            };
            color += c;
            match hit {
                Some((h, sp)) => {
                    samples[s as usize] = SampleHit { tri: h.tri, u: h.u, v: h.v };
                    covered += 1;
                    if nearest {
                        // The surface is needed for the pixel's representative hit.
                        // (Its shading normal: a trace without lights finds only that.)
                        let normal = sp.map_or_else(|| shading_normal(self.world, &h, ray.dir), |sp| sp.normal);
                        let hit = PixelHit { tri: h.tri, object: h.object, t: h.t, normal, u: h.u, v: h.v };
                        best = (centre_dist, hit, blocked);
                    }
                }
                None => {
                    samples[s as usize] = SampleHit::MISS;
                    if nearest {
                        best = (centre_dist, PixelHit::MISS, 0);
                    }
                }
            }
        }
        let hit = best.1;
        debug_assert!(hit.tri == NO_HIT || hit.object != NO_HIT);
        ((color / spp as f32).extend(covered as f32 / spp as f32), hit, best.2)
    }

    /// Traces `pixels` (all when None) of `frame` with `rays`, overwriting their colour, hit,
    /// occlusion and sample buffers. `facets`: each pixel's facet (None: one facet); `pixels`
    /// must be whole facets.
    ///
    /// With one sample per pixel, lights and shadows on, shadow rays are cast only where a
    /// light may be partly occluded: first at every other pixel of every other row (the
    /// coarse grid), then at the others only for the lights their coarse neighbours (same
    /// facet, same object) disagree on; the rest take the neighbours' answer. A shadow
    /// narrower than two pixels between coarse samples can be missed: `benches/pipeline.rs`
    /// measures the error against a 64-sample reference.
    pub fn render(
        &self,
        film: &mut Film,
        rays: &Rays,
        pixels: Option<&[u32]>,
        facets: Option<&[u32]>,
        progress: &Progress,
    ) {
        self.render_known(film, rays, pixels, facets, None, progress);
    }

    /// `render`, taking the centre hits `centre` knows (at one sample per pixel) instead of
    /// tracing those rays again: the same pixels when they are the closest hits of `rays`'
    /// centre rays.
    pub fn render_known(
        &self,
        film: &mut Film,
        rays: &Rays,
        pixels: Option<&[u32]>,
        facets: Option<&[u32]>,
        centre: Option<&KnownHits>,
        progress: &Progress,
    ) {
        let coarse_first = film.spp == 1 && self.rig.is_some_and(|r| r.shadows && !r.lights.is_empty());
        if !coarse_first {
            match pixels {
                None => self.render_rows(film, rays, progress, |_| true, |_| Known::NONE, centre),
                Some(list) => self.render_subset(film, rays, list, None, centre, progress),
            }
            return;
        }
        let w = film.width as usize;
        let on_grid = |i: usize| (i % w).is_multiple_of(2) && (i / w).is_multiple_of(2);
        let ids = facets.unwrap_or(&[]);
        let Some(list) = pixels else {
            // The whole film, in place (no copy of its buffers): the grid, then the others
            // with what their grid neighbours agree on.
            self.render_rows(film, rays, progress, on_grid, |_| Known::NONE, centre);
            let traced = &*film;
            let known: Vec<Known> = (0..traced.pixel_count())
                .into_par_iter()
                .map(|i| if on_grid(i) { Known::NONE } else { coarse_occlusion(traced, ids, i) })
                .collect();
            self.render_rows(film, rays, progress, |i| !on_grid(i), |i| known[i], centre);
            return;
        };
        let grid: Vec<u32> = list.par_iter().copied().filter(|&i| on_grid(i as usize)).collect();
        let rest: Vec<u32> = list.par_iter().copied().filter(|&i| !on_grid(i as usize)).collect();
        self.render_subset(film, rays, &grid, None, centre, progress);
        let traced = &*film;
        let known: Vec<Known> = rest.par_iter().map(|&i| coarse_occlusion(traced, ids, i as usize)).collect();
        self.render_subset(film, rays, &rest, Some(&known), centre, progress);
    }

    /// Every pixel, rows in parallel, every shadow ray cast.
    #[cfg(test)]
    fn render_all(&self, film: &mut Film, rays: &Rays, progress: &Progress) {
        self.render_rows(film, rays, progress, |_| true, |_| Known::NONE, None);
    }

    /// The pixels `pick` chooses, bands of `TILE` rows in parallel, in place, with what
    /// `known(i)` says of the lights of pixel `i`.
    fn render_rows(
        &self,
        film: &mut Film,
        rays: &Rays,
        progress: &Progress,
        pick: impl Fn(usize) -> bool + Sync,
        known: impl Fn(usize) -> Known + Sync,
        centre: Option<&KnownHits>,
    ) {
        let (w, h, spp) = (film.width, film.height, film.spp as usize);
        let wu = w as usize;
        // One sample per pixel and no hits known: the centre rays go as packets of four
        // (`Accel::closest4`), the same hits as one by one.
        let packets = spp == 1 && centre.is_none();
        for_each_band(film, TILE, |base, (c, hband, oband, sband)| {
            // Cancelled (cubist serve): the remaining bands are skipped; the caller checks
            // `progress.check()` and throws the film away.
            if progress.cancelled() {
                return;
            }
            let rows = c.len() / wu;
            let mut traced = 0u64;
            // Tile by tile across the band, row by row within a tile.
            for x0 in (0..wu).step_by(TILE) {
                let x1 = (x0 + TILE).min(wu);
                if packets {
                    // Pairs of rows with picked pixels (rows 0 and 1 of the tile, or 0 and 2 on
                    // the coarse grid), two pixels from each: 2 x 2 blocks of neighbours.
                    let mut trace_rows = |above: TileRow, below: &TileRow| {
                        for packet in above.blocks_with(below) {
                            for (j, ray, hit) in self.trace_packet(base, &packet.j[..packet.len], w, h, rays) {
                                let (i, px) = (base + j, &mut sband[j..j + 1]);
                                let centre = Some((&ray, hit));
                                (c[j], hband[j], oband[j]) =
                                    self.trace_pixel(i, w, h, px, rays, known(i), None, centre);
                                traced += 1;
                            }
                        }
                    };
                    let mut pending: Option<TileRow> = None;
                    for r in 0..rows {
                        let row = TileRow::picked(r * wu + x0..r * wu + x1, |j| pick(base + j));
                        if row.len > 0 {
                            match pending.take() {
                                Some(above) => trace_rows(above, &row),
                                None => pending = Some(row),
                            }
                        }
                    }
                    if let Some(last) = pending {
                        trace_rows(last, &TileRow::EMPTY);
                    }
                    continue;
                }
                for j in (0..rows).flat_map(|r| r * wu + x0..r * wu + x1) {
                    let i = base + j;
                    if !pick(i) {
                        continue;
                    }
                    let (col, hit, blocked) =
                        self.trace_pixel(i, w, h, &mut sband[j * spp..(j + 1) * spp], rays, known(i), centre, None);
                    c[j] = col;
                    hband[j] = hit;
                    oband[j] = blocked;
                    traced += 1;
                }
            }
            progress.add(traced);
        });
    }

    /// The centre rays of the band pixels `packet` (1 to 4 band offsets; the band starts at
    /// pixel `base`) and their closest hits, traced as one packet.
    fn trace_packet(
        &self,
        base: usize,
        packet: &[usize],
        width: u32,
        height: u32,
        rays: &Rays,
    ) -> impl Iterator<Item = (usize, CameraRay, Option<Hit>)> {
        let n = packet.len();
        let cam = packet_of(n, |l| {
            let i = base + packet[l];
            let (x, y) = (i as u32 % width, i as u32 / width);
            rays(i, screen_point(x, y, sample_offset(self.seed, i as u64, 0, 1), width, height))
        });
        let hits = self.closest_of(&cam, n);
        let packet: [usize; TileRow::PACKET] = std::array::from_fn(|l| packet[l.min(n - 1)]);
        (0..n).map(move |l| (packet[l], cam[l], hits[l]))
    }

    /// The closest hits of the first `n` rays of `packet`, as one packet (`Accel::closest4`).
    #[inline]
    fn closest_of(&self, packet: &[CameraRay; TileRow::PACKET], n: usize) -> [Option<Hit>; TileRow::PACKET] {
        let lanes: [(Vec3, Vec3); TileRow::PACKET] = packet.map(|r| (r.origin, r.dir));
        self.accel.closest4(&lanes[..n], 0.0, f32::INFINITY)
    }

    /// The pixels of `list`, in parallel chunks, with what `known[k]` says of the lights of
    /// `list[k]`.
    fn render_subset(
        &self,
        film: &mut Film,
        rays: &Rays,
        list: &[u32],
        known: Option<&[Known]>,
        centre: Option<&KnownHits>,
        progress: &Progress,
    ) {
        if list.windows(2).all(|p| p[0] < p[1]) {
            self.render_subset_in_place(film, rays, list, known, centre, progress);
            return;
        }
        let chunks = self.trace_subset(film, rays, list, known, centre, progress);
        write_subset(film, list, chunks);
    }

    /// `render_subset` for an ascending `list` (the re-trace's moved pixels, its grid and the
    /// rest): bands of rows in parallel, each tracing its pixels of `list` straight into the
    /// film. perf8 (issue 16): no result buffer for the whole list (about 27 MB of fresh pages
    /// for venus_11k's 480K moved pixels at 1000 x 1000) and no copy out of it. The same pixels:
    /// each is traced as before, only stored at once.
    fn render_subset_in_place(
        &self,
        film: &mut Film,
        rays: &Rays,
        list: &[u32],
        known: Option<&[Known]>,
        centre: Option<&KnownHits>,
        progress: &Progress,
    ) {
        if list.is_empty() {
            return;
        }
        let (w, h, spp) = (film.width, film.height, film.spp as usize);
        for_each_band_of(film, BAND_ROWS, list, |base, first, last, (color, hits, occlusion, samples)| {
            // Cancelled (cubist serve): the caller checks `progress.check()` and throws the
            // film away.
            if first == last || progress.cancelled() {
                return;
            }
            if spp == 1 && centre.is_none() {
                // Four pixels of the list at a time (mostly neighbours in a row, through the
                // same facet's rays) as one packet (`Accel::closest4`), the same hits.
                for (c, chunk) in list[first..last].chunks(TileRow::PACKET).enumerate() {
                    let js: [usize; TileRow::PACKET] =
                        std::array::from_fn(|l| chunk[l.min(chunk.len() - 1)] as usize - base);
                    for (l, (j, ray, hit)) in self.trace_packet(base, &js[..chunk.len()], w, h, rays).enumerate() {
                        let known = known.map_or(Known::NONE, |v| v[first + c * TileRow::PACKET + l]);
                        let px = &mut samples[j..j + 1];
                        (color[j], hits[j], occlusion[j]) =
                            self.trace_pixel(base + j, w, h, px, rays, known, None, Some((&ray, hit)));
                    }
                }
            } else {
                for (k, &i) in list.iter().enumerate().take(last).skip(first) {
                    let j = i as usize - base;
                    let known = known.map_or(Known::NONE, |v| v[k]);
                    let px = &mut samples[j * spp..(j + 1) * spp];
                    (color[j], hits[j], occlusion[j]) =
                        self.trace_pixel(i as usize, w, h, px, rays, known, centre, None);
                }
            }
            progress.add((last - first) as u64);
        });
    }

    /// `render_subset`'s tracing, reading nothing of `film` but its size and samples (so
    /// `centre` may read its hits); `write_subset` stores the result.
    fn trace_subset(
        &self,
        film: &Film,
        rays: &Rays,
        list: &[u32],
        known: Option<&[Known]>,
        centre: Option<&KnownHits>,
        progress: &Progress,
    ) -> Vec<SubsetChunk> {
        let (w, h, spp) = (film.width, film.height, film.spp as usize);
        list.par_chunks(CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let mut samples = vec![SampleHit::MISS; chunk.len() * spp];
                if progress.cancelled() {
                    return (vec![(Vec4::ZERO, PixelHit::MISS, 0); chunk.len()], samples);
                }
                let out = chunk
                    .iter()
                    .enumerate()
                    .map(|(k, &i)| {
                        let known = known.map_or(Known::NONE, |v| v[c * CHUNK + k]);
                        self.trace_pixel(
                            i as usize,
                            w,
                            h,
                            &mut samples[k * spp..(k + 1) * spp],
                            rays,
                            known,
                            centre,
                            None,
                        )
                    })
                    .collect();
                progress.add(chunk.len() as u64);
                (out, samples)
            })
            .collect()
    }

    /// Shades `pixels` of a film traced at one sample per pixel without lights
    /// (`pipeline::Shading::Deferred`): each takes its centre hit from `film` instead of
    /// tracing it again, and casts its shadow rays as `render` over the whole film would have
    /// (the coarse grid with no facets, then the others with what their grid neighbours agree
    /// on), so these pixels come out bit for bit as a lit trace of the whole film gives them.
    /// Grid pixels a wanted pixel reads are shaded too (and overwritten by whoever traces them
    /// later). `rays` must be the rays the film was traced with.
    pub fn shade_traced(&self, film: &mut Film, rays: &Rays, pixels: &[u32], progress: &Progress) {
        debug_assert_eq!(film.spp, 1, "a deferred pre-render traces one sample per pixel");
        let coarse_first = film.spp == 1 && self.rig.is_some_and(|r| r.shadows && !r.lights.is_empty());
        // In batches, each written before the next is traced: a batch's pixels read only
        // their own hits and (off the grid) grid pixels shaded before, and the memory held
        // for results stays a batch's, not the image's.
        let shade = |film: &mut Film, list: &[u32], coarse: bool| {
            for batch in list.chunks(SHADE_BATCH) {
                let traced = &*film;
                let known: Option<Vec<Known>> =
                    coarse.then(|| batch.par_iter().map(|&i| coarse_occlusion(traced, &[], i as usize)).collect());
                let centre = |i: usize| centre_hit(traced, i);
                let chunks = self.trace_subset(traced, rays, batch, known.as_deref(), Some(&centre), progress);
                write_subset(film, batch, chunks);
            }
        };
        if !coarse_first {
            shade(film, pixels, false);
            return;
        }
        let (w, h) = (film.width as usize, film.height as usize);
        let mut wanted = vec![false; w * h];
        for &i in pixels {
            wanted[i as usize] = true;
        }
        // The grid pixels (even x, even y) within one pixel of a wanted one: those a wanted
        // pixel's `coarse_occlusion` reads, and the wanted grid pixels themselves.
        let grid: Vec<u32> = (0..h)
            .into_par_iter()
            .step_by(2)
            .map(|y| {
                let (y0, y1) = (y.saturating_sub(1), (y + 1).min(h - 1));
                (0..w)
                    .step_by(2)
                    .filter(|&x| {
                        let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
                        (y0..=y1).any(|ny| wanted[ny * w + x0..=ny * w + x1].iter().any(|&b| b))
                    })
                    .map(|x| (y * w + x) as u32)
                    .collect::<Vec<u32>>()
            })
            .collect::<Vec<_>>()
            .concat();
        drop(wanted);
        let on_grid = |i: usize| (i % w).is_multiple_of(2) && (i / w).is_multiple_of(2);
        let rest: Vec<u32> = pixels.par_iter().copied().filter(|&i| !on_grid(i as usize)).collect();
        shade(film, &grid, false);
        shade(film, &rest, true);
    }

    /// The colour of pixel `i` from `spp` stratified samples (alpha: the fraction that hit),
    /// with the shadow rays `occlusion` answers left out. `centre` (only at 4 spp): the colour
    /// (and coverage) of the pixel's centre sample, already traced, taken as one of the 4
    /// samples with 3 new ones around it (`centre_rook_offset`; issue 16).
    #[allow(clippy::too_many_arguments)]
    fn supersample(
        &self,
        i: usize,
        width: u32,
        height: u32,
        spp: u32,
        rays: &Rays,
        known: Known,
        centre: Option<Vec4>,
    ) -> Vec4 {
        let (x, y) = (i as u32 % width, i as u32 / width);
        let (mut color, mut covered) = match centre {
            Some(c) => (c.truncate(), c.w),
            None => (Vec3::ZERO, 0.0),
        };
        let traced = if centre.is_some() { 3 } else { spp };
        // The pixel's rays, nearly parallel, go as packets of four (`Accel::closest4`); each
        // is shaded in turn, in the order of the samples (so the same sum).
        const PACKET: u32 = TileRow::PACKET as u32;
        for s0 in (0..traced).step_by(PACKET as usize) {
            let n = (traced - s0).min(PACKET) as usize;
            let ray = packet_of(n, |l| {
                let s = s0 + l as u32;
                let off = match centre {
                    Some(_) => centre_rook_offset(self.seed, i as u64, s),
                    None => sample_offset(self.seed, i as u64, s, spp),
                };
                rays(i, screen_point(x, y, off, width, height))
            });
            let hits = self.closest_of(&ray, n);
            for l in 0..n {
                let (c, hit, _) = self.sample_hit(&ray[l], known, hits[l]);
                color += c;
                covered += hit.is_some() as u32 as f32;
            }
        }
        (color / spp as f32).extend(covered / spp as f32)
    }

    /// Anti-aliasing (after the one-sample pre-render and re-trace): gives `pixels` `spp`
    /// samples each through `rays`, replacing their colour; hits stay those of the pixel
    /// centre. At 4 spp on a one-sample film the centre sample, already in the film, is one of
    /// the 4 and 3 new rays are traced around it (`supersample`); otherwise `spp` new
    /// stratified samples. A light whose occlusion the pixel's centre and its facet neighbours'
    /// agree on is taken as such for every sample (`Film::occlusion`): a shadow ray is cast
    /// only where the light is partly occluded. Each pixel's samples are seeded by the pixel,
    /// so the image is the same on any thread count.
    pub fn antialias(
        &self,
        film: &mut Film,
        rays: &Rays,
        pixels: &[u32],
        facets: &[u32],
        spp: u32,
        progress: &Progress,
    ) {
        let (w, h) = (film.width, film.height);
        let film_ref = &*film;
        let colours: Vec<Vec<Vec4>> = pixels
            .par_chunks(CHUNK)
            .map(|chunk| {
                let out = chunk
                    .iter()
                    .map(|&i| {
                        let known = agreed_occlusion(film_ref, facets, i as usize);
                        let centre = (film_ref.spp == 1 && spp == 4).then(|| film_ref.color[i as usize]);
                        self.supersample(i as usize, w, h, spp, rays, known, centre)
                    })
                    .collect();
                progress.add(chunk.len() as u64);
                out
            })
            .collect();
        for (chunk, out) in pixels.chunks(CHUNK).zip(colours) {
            for (&i, c) in chunk.iter().zip(out) {
                film.color[i as usize] = c;
            }
        }
    }
}

/// Pixel `i`'s centre hit as `film` holds it (one sample per pixel), for `KnownHits`.
#[inline]
fn centre_hit(film: &Film, i: usize) -> Option<Option<Hit>> {
    let h = &film.hits[i];
    Some(h.is_hit().then_some(Hit { tri: h.tri, object: h.object, t: h.t, u: h.u, v: h.v }))
}

/// Pixels from which `write_subset` writes in parallel (smaller lists, such as
/// `shade_traced`'s batches, cost more in tasks than they gain).
const PARALLEL_WRITE: usize = 1 << 16;

/// Stores `trace_subset`'s chunks for the pixels of `list` in `film`: bands of rows in
/// parallel when `list` is long and ascends (the re-trace's does; perf7, issue 16), else in
/// turn.
fn write_subset(film: &mut Film, list: &[u32], chunks: Vec<SubsetChunk>) {
    let spp = film.spp as usize;
    let parallel = list.len() >= PARALLEL_WRITE && list.windows(2).all(|p| p[0] < p[1]);
    if !parallel {
        for (chunk, (out, samples)) in list.chunks(CHUNK).zip(chunks) {
            for (k, &i) in chunk.iter().enumerate() {
                let i = i as usize;
                (film.color[i], film.hits[i], film.occlusion[i]) = out[k];
                film.samples[i * spp..(i + 1) * spp].copy_from_slice(&samples[k * spp..(k + 1) * spp]);
            }
        }
        return;
    }
    let chunks = &chunks;
    for_each_band_of(film, 16, list, |base, first, last, (color, hits, occlusion, samples)| {
        for (k, &i) in list.iter().enumerate().take(last).skip(first) {
            let j = i as usize - base;
            let (out, traced) = &chunks[k / CHUNK];
            let c = k % CHUNK;
            (color[j], hits[j], occlusion[j]) = out[c];
            samples[j * spp..(j + 1) * spp].copy_from_slice(&traced[c * spp..(c + 1) * spp]);
        }
    });
}

/// A band of `rows` rows of a film's per-pixel buffers: colour, hits, occlusion and samples.
type FilmBand<'a> = (&'a mut [Vec4], &'a mut [PixelHit], &'a mut [u8], &'a mut [SampleHit]);

/// Calls `f(base, band)` for each band of `rows` rows of `film`, in parallel; `base` is the
/// band's first pixel.
fn for_each_band<F>(film: &mut Film, rows: usize, f: F)
where
    F: Fn(usize, FilmBand<'_>) + Sync,
{
    let band = film.width as usize * rows;
    let spp = film.spp as usize;
    film.color
        .par_chunks_mut(band)
        .zip(film.hits.par_chunks_mut(band))
        .zip(film.occlusion.par_chunks_mut(band))
        .zip(film.samples.par_chunks_mut(band * spp))
        .enumerate()
        .for_each(|(b, (((color, hits), occlusion), samples))| f(b * band, (color, hits, occlusion, samples)));
}

/// `for_each_band`, calling `f(base, first, last, band)`: `list[first..last]` are the pixels of
/// the ascending `list` inside the band (what the in-place re-trace and `write_subset` store,
/// band by band).
fn for_each_band_of<F>(film: &mut Film, rows: usize, list: &[u32], f: F)
where
    F: Fn(usize, usize, usize, FilmBand<'_>) + Sync,
{
    for_each_band(film, rows, |base, band| {
        let first = list.partition_point(|&i| (i as usize) < base);
        let last = list.partition_point(|&i| (i as usize) < base + band.0.len());
        f(base, first, last, band);
    });
}

/// The 8-neighbours of pixel `i` in the same facet, and `i` itself: what `agreed_occlusion`
/// and `pixels_to_refine` compare (written as loops there; the tests hold them to this).
#[cfg(test)]
fn facet_neighbourhood(width: usize, height: usize, facets: &[u32], i: usize) -> impl Iterator<Item = usize> + '_ {
    let (x, y) = ((i % width) as isize, (i / width) as isize);
    let f = facets[i];
    (-1..=1isize)
        .flat_map(move |dy| (-1..=1isize).map(move |dx| (x + dx, y + dy)))
        .filter(move |&(nx, ny)| nx >= 0 && ny >= 0 && (nx as usize) < width && (ny as usize) < height)
        .map(move |(nx, ny)| ny as usize * width + nx as usize)
        .filter(move |&j| facets[j] == f)
}

/// The occlusion of some lights, known across a pixel for samples that hit `object`.
#[derive(Clone, Copy, Debug)]
struct Known {
    occlusion: Occlusion,
    object: u32,
}

impl Known {
    const NONE: Known = Known { occlusion: Occlusion::TRACE, object: NO_HIT };

    /// What is known for a sample that hit `h` (nothing on another object).
    #[inline]
    fn for_hit(&self, h: &Hit) -> Occlusion {
        if h.object == self.object { self.occlusion } else { Occlusion::TRACE }
    }
}

/// The lights the pixels `js` that hit all agree on, when they hit one object.
fn agree(film: &Film, js: impl Iterator<Item = usize>) -> Known {
    let (mut all_blocked, mut any_blocked, mut object) = (u8::MAX, 0u8, NO_HIT);
    for j in js {
        let hit = &film.hits[j];
        if !hit.is_hit() {
            continue;
        }
        if object != NO_HIT && hit.object != object {
            return Known::NONE;
        }
        object = hit.object;
        all_blocked &= film.occlusion[j];
        any_blocked |= film.occlusion[j];
    }
    if object == NO_HIT {
        return Known::NONE;
    }
    let known = all_blocked | !any_blocked;
    Known { occlusion: Occlusion { known, blocked: all_blocked & known }, object }
}

/// serve5 (issue 14): what anti-aliasing takes as known of pixel `i`'s lights
/// (`agreed_occlusion`), as one number: a pixel refined through the same rays with the same
/// number gets the same colour (a session reuses it, `pipeline::stages::antialias_stage`).
pub fn antialias_known(film: &Film, facets: &[u32], i: usize) -> u64 {
    let k = agreed_occlusion(film, facets, i);
    // The centre's own lights blocked too: its colour is one of the samples (`supersample`),
    // and the lights its neighbours disagree on are not in `k`.
    let own = film.occlusion[i] as u64;
    (own << 48) | ((k.object as u64) << 16) | ((k.occlusion.known as u64) << 8) | k.occlusion.blocked as u64
}

/// The lights whose occlusion pixel `i`'s centre sample and those of its facet neighbours
/// agree on (SPEC: cast shadow rays only where a light is partly occluded).
fn agreed_occlusion(film: &Film, facets: &[u32], i: usize) -> Known {
    // `facet_neighbourhood`'s pixels, gathered by plain loops (its chain of iterators cost
    // more than `agree` itself; `agree` does not depend on their order). perf8, issue 16.
    let (w, h) = (film.width as usize, film.height as usize);
    let (x, y) = (i % w, i / w);
    let f = facets[i];
    let mut js = [0usize; 9];
    let mut n = 0;
    for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
        for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
            let j = ny * w + nx;
            if facets[j] == f {
                js[n] = j;
                n += 1;
            }
        }
    }
    agree(film, js[..n].iter().copied())
}

/// What the coarse grid (even x, even y) around pixel `i` agrees on, in its facet (`facets`
/// empty: one facet).
fn coarse_occlusion(film: &Film, facets: &[u32], i: usize) -> Known {
    // `coarse_grid_around`'s pixels by plain loops, as `agreed_occlusion` gathers its own.
    let (w, h) = (film.width as usize, film.height as usize);
    let (x, y) = (i % w, i / w);
    let (lx, ly) = (x - x % 2, y - y % 2);
    let nx = if x % 2 == 1 && lx + 2 < w { 2 } else { 1 };
    let ny = if y % 2 == 1 && ly + 2 < h { 2 } else { 1 };
    let mut js = [0usize; 4];
    let mut n = 0;
    for dy in 0..ny {
        for dx in 0..nx {
            let j = (ly + 2 * dy) * w + lx + 2 * dx;
            if facets.is_empty() || facets[j] == facets[i] {
                js[n] = j;
                n += 1;
            }
        }
    }
    agree(film, js[..n].iter().copied())
}

/// The coarse shadow grid's pixels (even x, even y) `coarse_occlusion` reads for pixel `i` of
/// a `w` x `h` film: `i` itself on the grid, else the two or four grid pixels around it. A
/// session's re-trace reuses a pixel only while these keep their facet relation
/// (`pipeline::session`).
#[inline]
pub(crate) fn coarse_grid_around(w: usize, h: usize, i: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    let around = |c: usize, n: usize| {
        let lo = c - c % 2;
        [Some(lo), (c % 2 == 1 && lo + 2 < n).then_some(lo + 2)]
    };
    let (xs, ys) = (around(x, w), around(y, h));
    ys.into_iter().flatten().flat_map(move |cy| xs.into_iter().flatten().map(move |cx| cy * w + cx))
}

/// The pixels adaptive anti-aliasing gives more samples: those whose one-sample colour differs
/// from a neighbour of the same facet by more than `threshold` (sRGB, any channel), or that
/// show another object, or hit where the neighbour misses. Pixels across a facet border are
/// not compared: each pixel is traced through its own facet's rays, and the border is a pixel
/// edge. All pixels when `threshold` is 0.
pub fn pixels_to_refine(film: &Film, facets: &[u32], threshold: f32) -> Vec<u32> {
    let n = film.pixel_count();
    if threshold <= 0.0 {
        return (0..n as u32).collect();
    }
    if n == 0 {
        return Vec::new();
    }
    // Each pixel's object and 8-bit sRGB codes (the encoder's threshold table, not a power per
    // channel) in one word, rows in parallel: every pixel is read by its 8 neighbours, so
    // they read 8 bytes, not a 32-byte hit and a colour. perf8 (issue 16).
    let (w, h) = (film.width as usize, film.height as usize);
    let lut = Srgb8::get();
    let mut keys = vec![0u64; n];
    keys.par_chunks_mut(w).zip(film.color.par_chunks(w)).zip(film.hits.par_chunks(w)).for_each(
        |((out, colour), hits)| {
            for ((o, c), hit) in out.iter_mut().zip(colour).zip(hits) {
                let rgb = (lut.code(c.x) as u64) << 16 | (lut.code(c.y) as u64) << 8 | lut.code(c.z) as u64;
                *o = (hit.object as u64) << 32 | rgb;
            }
        },
    );
    let limit = (threshold * 255.0).round().max(1.0) as i32;
    // Another object, or a channel's codes further apart than `limit` (no short cut, so the
    // loops below run without branches).
    let differs = |a: u64, b: u64| {
        let far = |s: u32| (((a >> s) & 0xff) as i32 - ((b >> s) & 0xff) as i32).abs() > limit;
        ((a >> 32) != (b >> 32)) | far(0) | far(8) | far(16)
    };
    // Marks in `flag` the pixels of row `a` that differ from their partner in row `b` of the
    // same facet (the slices already shifted by the neighbour's offset).
    let mark = |flag: &mut [bool], (ka, fa): (&[u64], &[u32]), (kb, fb): (&[u64], &[u32])| {
        for ((((f, &ka), &fa), &kb), &fb) in flag.iter_mut().zip(ka).zip(fa).zip(kb).zip(fb) {
            *f |= (fa == fb) & differs(ka, kb);
        }
    };
    // Each row's pixels whose facet neighbours (`facet_neighbourhood`) disagree, in order.
    let rows: Vec<Vec<u32>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row = |r: usize| (&keys[r * w..(r + 1) * w], &facets[r * w..(r + 1) * w]);
            let (k0, f0) = row(y);
            let mut flag = vec![false; w];
            for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                let (k1, f1) = row(ny);
                // Neighbour x - 1, then x + 1, then x itself in the rows above and below.
                mark(&mut flag[1..], (&k0[1..], &f0[1..]), (&k1[..w - 1], &f1[..w - 1]));
                mark(&mut flag[..w - 1], (&k0[..w - 1], &f0[..w - 1]), (&k1[1..], &f1[1..]));
                if ny != y {
                    mark(&mut flag, (k0, f0), (k1, f1));
                }
            }
            flag.iter().enumerate().filter(|&(_, &f)| f).map(|(x, _)| (y * w + x) as u32).collect()
        })
        .collect();
    rows.concat()
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
    fn the_centre_rooks_are_latin_leave_the_middle_and_vary() {
        let mut perms = std::collections::HashSet::new();
        for pixel in 0..1000u64 {
            let cells: Vec<(u32, u32)> = (0..3)
                .map(|s| {
                    let o = centre_rook_offset(7, pixel, s);
                    assert!((0.0..1.0).contains(&o.x) && (0.0..1.0).contains(&o.y), "{o}");
                    ((o.x * 3.0) as u32, (o.y * 3.0) as u32)
                })
                .collect();
            // One per column and per row, none in the middle cell (the centre sample's).
            let (mut cols, mut rows) = ([0; 3], [0; 3]);
            for &(cx, cy) in &cells {
                cols[cx as usize] += 1;
                rows[cy as usize] += 1;
                assert_ne!((cx, cy), (1, 1), "pixel {pixel}: {cells:?}");
            }
            assert_eq!((cols, rows), ([1; 3], [1; 3]), "pixel {pixel}: {cells:?}");
            perms.insert(cells);
        }
        // All 4 such permutations are used.
        assert_eq!(perms.len(), 4);
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

    /// A film of `w x h` one-sample pixels, every one a hit on object 0 in mid grey.
    fn grey_film(w: u32, h: u32) -> Film {
        let mut film = Film::new(w, h, 1);
        for (c, hit) in film.color.iter_mut().zip(&mut film.hits) {
            *c = Vec4::new(0.2, 0.2, 0.2, 1.0);
            *hit = PixelHit { tri: 0, object: 0, t: 1.0, normal: Vec3::Z, u: 0.0, v: 0.0 };
        }
        film
    }

    #[test]
    fn only_pixels_whose_facet_neighbours_disagree_are_refined() {
        let (w, h) = (8u32, 6u32);
        let one_facet = vec![0u32; 48];
        let mut film = grey_film(w, h);
        assert!(pixels_to_refine(&film, &one_facet, 0.02).is_empty(), "a flat film needs no samples");
        assert_eq!(pixels_to_refine(&film, &one_facet, 0.0).len(), 48, "threshold 0: every pixel");
        // A change below the threshold (sRGB) is not refined; one above it refines the pixel
        // and its 8 neighbours.
        film.color[2 * 8 + 3] = Vec4::new(0.201, 0.2, 0.2, 1.0);
        assert!(pixels_to_refine(&film, &one_facet, 0.02).is_empty());
        film.color[2 * 8 + 3] = Vec4::new(0.5, 0.2, 0.2, 1.0);
        let want: Vec<u32> = (1..=3).flat_map(|y| (2..=4).map(move |x| y * 8 + x)).collect();
        assert_eq!(pixels_to_refine(&film, &one_facet, 0.02), want);
        // Another object (same colour) is a silhouette: refined with its neighbours.
        let mut film = grey_film(w, h);
        film.hits[0].object = 1;
        assert_eq!(pixels_to_refine(&film, &one_facet, 0.02), vec![0, 1, 8, 9]);
        // Across a facet border nothing is compared: columns 0..4 facet 0, 4..8 facet 1, each
        // flat but of different colours.
        let mut film = grey_film(w, h);
        let facets: Vec<u32> = (0..48).map(|i| (i % 8 >= 4) as u32).collect();
        for i in 0..48 {
            if facets[i] == 1 {
                film.color[i] = Vec4::new(0.9, 0.1, 0.1, 1.0);
            }
        }
        assert!(pixels_to_refine(&film, &facets, 0.02).is_empty());
    }

    /// perf8: the word-per-pixel comparison in shifted rows picks exactly the pixels the
    /// plain loop over each pixel's facet neighbours picks, on random films with a few
    /// facets, objects, misses and colours near the threshold.
    #[test]
    fn pixels_to_refine_matches_the_neighbour_loop() {
        let reference = |film: &Film, facets: &[u32], threshold: f32| -> Vec<u32> {
            let (w, h) = (film.width as usize, film.height as usize);
            let code = |i: usize| {
                let c = film.color[i];
                [c.x, c.y, c.z].map(|v| crate::scene::srgb::srgb8(v) as i32)
            };
            let limit = (threshold * 255.0).round().max(1.0) as i32;
            (0..w * h)
                .filter(|&i| {
                    facet_neighbourhood(w, h, facets, i).any(|j| {
                        let (a, b) = (code(i), code(j));
                        j != i
                            && (film.hits[i].object != film.hits[j].object
                                || (0..3).any(|c| (a[c] - b[c]).abs() > limit))
                    })
                })
                .map(|i| i as u32)
                .collect()
        };
        let mut state = 7u64;
        let mut next = || {
            state = splitmix64(state);
            state
        };
        for (w, h) in [(1u32, 1u32), (1, 9), (9, 1), (2, 2), (37, 23), (64, 40)] {
            let n = (w * h) as usize;
            let mut film = grey_film(w, h);
            let facets: Vec<u32> = (0..n).map(|_| (next() % 3) as u32).collect();
            for i in 0..n {
                let r = next();
                film.color[i] = Vec4::new(0.2 + (r % 8) as f32 * 0.002, 0.2, 0.2 + ((r >> 8) % 3) as f32 * 0.05, 1.0);
                match (r >> 16) % 10 {
                    0 => film.hits[i] = PixelHit::MISS,
                    1 => film.hits[i].object = 1,
                    _ => {}
                }
            }
            for threshold in [0.005, 0.02, 0.1] {
                let want = reference(&film, &facets, threshold);
                assert_eq!(pixels_to_refine(&film, &facets, threshold), want, "{w} x {h}, threshold {threshold}");
                if w * h > 100 {
                    assert!(!want.is_empty() && want.len() < n, "{w} x {h}: some refined, not all");
                }
            }
        }
    }

    /// The built-in still life, its default stage parameters at `width x height` and one sample
    /// per pixel, and its lit pre-render.
    fn still_life_prerender(
        width: u32,
        height: u32,
    ) -> (crate::pipeline::Prepared, crate::pipeline::StageParams, crate::pipeline::PreRender) {
        use crate::pipeline::{Prepared, Shading, StageParams, Timings, prerender};
        use crate::settings::Settings;
        let prep = Prepared::load(None).unwrap();
        let params = StageParams::new(&Settings { width, height, spp: 1, ..Settings::default() });
        let pre = prerender(
            &prep,
            &params.framing,
            &params.trace,
            Shading::Lit,
            &Progress::silent(),
            &mut Timings::default(),
        )
        .unwrap();
        (prep, params, pre)
    }

    /// perf8: an ascending list is traced in place by bands of rows; it gives the film the
    /// pixels the chunked trace and copy (any order) gives it, sparse shadow rays included,
    /// on 1 and 3 threads.
    #[test]
    fn subset_traced_in_place_matches_the_chunked_trace() {
        let (prep, params, pre) = still_life_prerender(163, 97);
        let tracer = pre.view.tracer(&prep, &params.trace);
        let camera = pre.view.framed.camera.as_ref();
        // A moved ray: the camera's, shifted, so the subset's pixels really change.
        let rays = |_: usize, p: DVec2| camera.ray(p + DVec2::new(0.01, 0.0));
        let (w, n) = (163usize, 163 * 97);
        let facets: Vec<u32> = (0..n).map(|i| ((i % w) / 20 + (i / w) / 15) as u32 % 4).collect();
        let list: Vec<u32> = (0..n as u32).filter(|&i| facets[i as usize] == 1).collect();
        // Reversed in fives: not ascending, so the chunked trace and `write_subset` store it.
        let mut unordered = list.clone();
        unordered.chunks_mut(5).for_each(|c| c.reverse());
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let run = |l: &[u32]| {
                let mut film = pre.film.clone();
                pool.install(|| tracer.render(&mut film, &rays, Some(l), Some(&facets), &Progress::silent()));
                film
            };
            let (a, b) = (run(&list), run(&unordered));
            assert!(a.hits != pre.film.hits, "the subset was traced again");
            assert_eq!(
                a.color.iter().map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<_>>(),
                b.color.iter().map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<_>>()
            );
            assert!(a.hits == b.hits && a.occlusion == b.occlusion && a.samples == b.samples);
        }
    }

    /// perf16: the whole film traced by `render_rows` (centre rays in 2 x 2 packets) and the
    /// anti-aliasing (each pixel's rays as one packet) give the pixels tracing one ray at a
    /// time gives (the chunked subset trace; `supersample`'s rays one by one), bit for bit, on
    /// odd and even sizes, lit (the coarse shadow grid first) and hits only.
    #[test]
    fn packets_trace_what_single_rays_trace() {
        for (w, h) in [(163u32, 97u32), (64, 48), (7, 5)] {
            let (prep, params, pre) = still_life_prerender(w, h);
            let camera = pre.view.framed.camera.as_ref();
            let rays = |_: usize, p: DVec2| camera.ray(p);
            let n = (w * h) as usize;
            for lit in [true, false] {
                let mut tracer = pre.view.tracer(&prep, &params.trace);
                if !lit {
                    tracer.rig = None;
                }
                let mut packets = Film::to_be_traced(w, h, 1);
                tracer.render(&mut packets, &rays, None, None, &Progress::silent());
                // Every pixel, not ascending: traced one by one in chunks.
                let mut list: Vec<u32> = (0..n as u32).collect();
                list.chunks_mut(3).for_each(|c| c.reverse());
                let mut single = Film::to_be_traced(w, h, 1);
                if lit {
                    // As `render_known` does for a whole film: the grid, then the rest.
                    let on_grid = |i: u32| (i % w).is_multiple_of(2) && (i / w).is_multiple_of(2);
                    let grid: Vec<u32> = list.iter().copied().filter(|&i| on_grid(i)).collect();
                    let rest: Vec<u32> = list.iter().copied().filter(|&i| !on_grid(i)).collect();
                    tracer.render_subset(&mut single, &rays, &grid, None, None, &Progress::silent());
                    let known: Vec<Known> = rest.iter().map(|&i| coarse_occlusion(&single, &[], i as usize)).collect();
                    tracer.render_subset(&mut single, &rays, &rest, Some(&known), None, &Progress::silent());
                } else {
                    tracer.render_subset(&mut single, &rays, &list, None, None, &Progress::silent());
                }
                let bits = |f: &Film| f.color.iter().map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<_>>();
                assert_eq!(bits(&packets), bits(&single), "{w} x {h}, lit {lit}");
                assert!(packets.hits == single.hits && packets.occlusion == single.occlusion, "{w} x {h}, lit {lit}");
                assert!(packets.hits.iter().filter(|h| h.tri != NO_HIT).count() > n / 4, "the rays must mostly hit");
                if lit {
                    // Anti-aliasing of every pixel: its rays as packets, against one by one.
                    let facets = vec![0u32; n];
                    let all: Vec<u32> = (0..n as u32).collect();
                    for spp in [4u32, 6] {
                        let mut aa = packets.clone();
                        tracer.antialias(&mut aa, &rays, &all, &facets, spp, &Progress::silent());
                        for i in 0..n {
                            let known = agreed_occlusion(&packets, &facets, i);
                            let centre = (spp == 4).then(|| packets.color[i]);
                            let (x, y) = (i as u32 % w, i as u32 / w);
                            let traced = if centre.is_some() { 3 } else { spp };
                            let (mut color, mut covered) = centre.map_or((Vec3::ZERO, 0.0), |c| (c.truncate(), c.w));
                            for s in 0..traced {
                                let off = match centre {
                                    Some(_) => centre_rook_offset(tracer.seed, i as u64, s),
                                    None => sample_offset(tracer.seed, i as u64, s, spp),
                                };
                                let (c, hit, _) = tracer.sample(&rays(i, screen_point(x, y, off, w, h)), known);
                                color += c;
                                covered += hit.is_some() as u32 as f32;
                            }
                            let want = (color / spp as f32).extend(covered / spp as f32);
                            assert_eq!(aa.color[i].to_array().map(f32::to_bits), want.to_array().map(f32::to_bits));
                        }
                        assert!(aa.color != packets.color, "anti-aliasing changed some pixels");
                    }
                }
            }
        }
    }

    /// perf8: the loops gathering the neighbours of `agreed_occlusion` and `coarse_occlusion`
    /// agree with `facet_neighbourhood` and `coarse_grid_around` on random films of odd and
    /// even sizes, with and without facets.
    #[test]
    fn neighbour_loops_match_the_neighbourhood_iterators() {
        let mut state = 11u64;
        let mut next = || {
            state = splitmix64(state);
            state
        };
        for (w, h) in [(1u32, 1u32), (1, 6), (7, 1), (2, 3), (9, 8), (16, 11)] {
            let n = (w * h) as usize;
            let mut film = grey_film(w, h);
            for i in 0..n {
                let r = next();
                film.occlusion[i] = (r % 4) as u8;
                match (r >> 8) % 8 {
                    0 => film.hits[i] = PixelHit::MISS,
                    1 => film.hits[i].object = 1,
                    _ => {}
                }
            }
            let facets: Vec<u32> = (0..n).map(|_| (next() % 2) as u32).collect();
            let key = |k: Known| (k.object, k.occlusion);
            for i in 0..n {
                let (wu, hu) = (w as usize, h as usize);
                let want = agree(&film, facet_neighbourhood(wu, hu, &facets, i));
                assert_eq!(key(agreed_occlusion(&film, &facets, i)), key(want), "{w} x {h}, pixel {i}");
                for ids in [&facets[..], &[]] {
                    let same = |j: &usize| ids.is_empty() || ids[*j] == ids[i];
                    let want = agree(&film, coarse_grid_around(wu, hu, i).filter(same));
                    assert_eq!(key(coarse_occlusion(&film, ids, i)), key(want), "{w} x {h}, pixel {i}");
                }
            }
        }
    }

    #[test]
    fn occlusion_is_known_only_where_neighbours_agree() {
        let mut film = grey_film(4, 4);
        let facets = vec![0u32; 16];
        // Light 0 blocked everywhere, light 1 blocked at one pixel only.
        film.occlusion.iter_mut().for_each(|o| *o = 0b01);
        film.occlusion[5] = 0b11;
        let k = agreed_occlusion(&film, &facets, 15);
        assert_eq!(k.occlusion.known & 0b11, 0b11, "pixel 15's neighbourhood agrees on both lights");
        assert_eq!(k.occlusion.blocked & 0b11, 0b01);
        let k = agreed_occlusion(&film, &facets, 10);
        assert_eq!(k.occlusion.known & 0b11, 0b01, "pixel 10 sees pixel 5: light 1 must be traced");
        assert_eq!(k.occlusion.blocked & 0b01, 0b01);
        // Only for samples on the same object.
        let other = Hit { t: 1.0, tri: 0, object: 3, u: 0.0, v: 0.0 };
        assert_eq!(k.for_hit(&other), Occlusion::TRACE);
        // Neighbours on two objects: nothing known.
        film.hits[1].object = 2;
        assert_eq!(agreed_occlusion(&film, &facets, 0).occlusion, Occlusion::TRACE);
    }

    /// The coarse-grid shadow rays (one sample per pixel: shadow rays only where coarse
    /// neighbours disagree) against casting every one, on the default still life with its
    /// cast shadows: the grid pixels are exact, and the others differ only at a few.
    #[test]
    fn coarse_shadow_rays_match_casting_every_one() {
        let (prep, params, pre) = still_life_prerender(160, 120);
        assert!(params.trace.shadows);
        let coarse = pre.film;
        let tracer = pre.view.tracer(&prep, &params.trace);
        let camera = pre.view.framed.camera.as_ref();
        let mut full = Film::new(160, 120, 1);
        tracer.render_all(&mut full, &|_, p| camera.ray(p), &Progress::silent());
        let blocked = full.occlusion.iter().filter(|&&o| o != 0).count();
        let lit = full.occlusion.iter().zip(&full.hits).filter(|(o, h)| **o == 0 && h.is_hit()).count();
        assert!(blocked > 200 && lit > 200, "the still life has shadows and light: {blocked} blocked, {lit} lit");
        let mut wrong = 0;
        for i in 0..full.pixel_count() {
            let on_grid = (i % 160) % 2 == 0 && (i / 160) % 2 == 0;
            assert_eq!(coarse.hits[i].tri, full.hits[i].tri);
            if on_grid {
                assert_eq!(coarse.color[i], full.color[i], "grid pixel {i}");
                assert_eq!(coarse.occlusion[i], full.occlusion[i], "grid pixel {i}");
            } else if coarse.occlusion[i] != full.occlusion[i] {
                wrong += 1;
            }
        }
        assert!(wrong * 200 < full.pixel_count(), "{wrong} pixels' shadows differ (of {})", full.pixel_count());
    }

    /// A deferred pre-render (hits only) shaded afterwards on some pixels gives those pixels
    /// bit for bit what the lit pre-render gives them, shadows of the coarse grid included,
    /// and the hits of every pixel; on 1 and 3 threads.
    #[test]
    fn deferred_shading_matches_the_lit_pre_render() {
        use crate::pipeline::{Prepared, Shading, StageParams, Timings, prerender};
        use crate::settings::Settings;
        let prep = Prepared::load(None).unwrap();
        let s = Settings { width: 161, height: 119, spp: 1, ..Settings::default() };
        let params = StageParams::new(&s);
        assert!(params.trace.shadows);
        let pre = |shading| {
            prerender(&prep, &params.framing, &params.trace, shading, &Progress::silent(), &mut Timings::default())
                .unwrap()
        };
        let lit = pre(Shading::Lit);
        let (w, n) = (161usize, 161 * 119);
        // Blocks of 7 x 5 pixels kept, the others left (as facets the re-trace takes).
        let kept: Vec<u32> =
            (0..n as u32).filter(|&i| !((i as usize % w) / 7 + (i as usize / w) / 5).is_multiple_of(3)).collect();
        let blocked = kept.iter().filter(|&&i| lit.film.occlusion[i as usize] != 0).count();
        assert!(blocked > 100 && kept.len() > n / 2, "shadows among the kept pixels: {blocked}");
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut deferred = pool.install(|| pre(Shading::Deferred));
            assert!(deferred.unshaded && !lit.unshaded);
            assert_eq!(deferred.film.hits, lit.film.hits, "the hits need no lights");
            let tracer = deferred.view.tracer(&prep, &params.trace);
            let camera = deferred.view.framed.camera.as_ref();
            let rays = camera.centre_rays(161, 119);
            pool.install(|| tracer.shade_traced(&mut deferred.film, &*rays, &kept, &Progress::silent()));
            for &i in &kept {
                let i = i as usize;
                assert_eq!(
                    deferred.film.color[i].to_array().map(f32::to_bits),
                    lit.film.color[i].to_array().map(f32::to_bits),
                    "pixel {i}"
                );
                assert_eq!(deferred.film.occlusion[i], lit.film.occlusion[i], "pixel {i}");
                assert_eq!(deferred.film.hits[i], lit.film.hits[i]);
                assert_eq!(deferred.film.samples[i], lit.film.samples[i]);
            }
        }
    }

    /// `write_subset` in parallel bands (perf7) stores what the serial loop stores, for lists
    /// long enough to take the parallel path and for short or unordered ones.
    #[test]
    fn write_subset_in_bands_matches_the_serial_loop() {
        let (w, h, spp) = (600u32, 400u32, 2usize);
        let fill = |i: u32| {
            let hit = PixelHit { tri: i, object: i % 5, t: i as f32 * 0.5, normal: Vec3::Y, u: 0.25, v: 0.5 };
            (Vec4::splat(i as f32), hit, (i % 7) as u8)
        };
        let stride3: Vec<u32> = (0..w * h).filter(|i| i % 3 == 0).collect();
        let short: Vec<u32> = (0..w * h).filter(|i| i % 17 == 0).take(5000).collect();
        let mut unordered = stride3.clone();
        unordered.swap(10, 20_000);
        for list in [stride3, short, unordered] {
            let chunks: Vec<SubsetChunk> = list
                .chunks(CHUNK)
                .map(|c| {
                    let out = c.iter().map(|&i| fill(i)).collect();
                    let samples = c
                        .iter()
                        .flat_map(|&i| (0..spp as u32).map(move |s| SampleHit { tri: i * 2 + s, u: 0.1, v: 0.2 }))
                        .collect();
                    (out, samples)
                })
                .collect();
            let mut want = Film::new(w, h, spp as u32);
            for (chunk, (out, samples)) in list.chunks(CHUNK).zip(&chunks) {
                for (k, &i) in chunk.iter().enumerate() {
                    let i = i as usize;
                    (want.color[i], want.hits[i], want.occlusion[i]) = out[k];
                    want.samples[i * spp..(i + 1) * spp].copy_from_slice(&samples[k * spp..(k + 1) * spp]);
                }
            }
            let mut got = Film::new(w, h, spp as u32);
            write_subset(&mut got, &list, chunks);
            assert!(got.color == want.color && got.hits == want.hits, "{} pixels", list.len());
            assert!(got.occlusion == want.occlusion && got.samples == want.samples);
        }
    }

    #[test]
    fn seeds_change_the_jitter() {
        assert_ne!(sample_offset(1, 5, 0, 4), sample_offset(2, 5, 0, 4));
        assert_eq!(sample_offset(1, 5, 0, 4), sample_offset(1, 5, 0, 4));
    }
}
