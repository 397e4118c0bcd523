//! The trace loop: rayon over bands of square tiles, or over chunks of a pixel subset (the
//! re-trace of moved facets), each sample shaded and every hit buffer written.

use super::*;

/// One chunk of a pixel-subset re-trace: each pixel's colour, hit and lights blocked, then its
/// samples' hits.
pub(super) type SubsetChunk = (Vec<(Vec4, PixelHit, u8)>, Vec<SampleHit>);

/// Side in pixels of the square tiles `Tracer::render_rows` traces one after another (bands of
/// `TILE` rows in parallel). Why: neighbouring rays walk mostly the same BVH nodes and
/// triangles, so a tile's rays likely find them still in cache (the likely reason, not
/// measured; the other stages' sparser pixel lists were slower in tiles). Each pixel is traced
/// as before, only in another order (same bits). Measured on the 1M-triangle scene at
/// 1000 x 1000: the pre-render 0.93x CPU.
pub(super) const TILE: usize = 16;

/// The picked pixels of one row of a tile (band offsets, ascending), and the 2 x 2 packets
/// two such rows make (`Tracer::render_rows`).
#[derive(Clone, Copy)]
pub(super) struct TileRow {
    pub(super) j: [usize; TILE],
    pub(super) len: usize,
}

impl TileRow {
    /// Rays per packet (`Accel::closest4`).
    pub(super) const PACKET: usize = 4;
    pub(super) const EMPTY: TileRow = TileRow { j: [0; TILE], len: 0 };

    /// The offsets of `row` that `pick` keeps.
    pub(super) fn picked(row: std::ops::Range<usize>, pick: impl Fn(usize) -> bool) -> TileRow {
        let mut out = TileRow::EMPTY;
        for j in row.filter(|&j| pick(j)) {
            out.j[out.len] = j;
            out.len += 1;
        }
        out
    }

    /// Packets of up to four: two pixels of `self` and the two below them in `below`, in
    /// turn; where one row runs out, up to four of the other's.
    pub(super) fn blocks_with(self, below: &TileRow) -> impl Iterator<Item = TileRow> + '_ {
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
pub(super) fn packet_of(n: usize, mut ray: impl FnMut(usize) -> CameraRay) -> [CameraRay; TileRow::PACKET] {
    debug_assert!((1..=TileRow::PACKET).contains(&n));
    let mut out = [ray(0); TileRow::PACKET];
    for l in 1..TileRow::PACKET {
        out[l] = if l < n { ray(l) } else { out[l - 1] };
    }
    out
}

/// Rows per parallel work item of `Tracer::render_subset_in_place` (4000 pixels at 1000 wide:
/// small enough that bands full of moved pixels and empty ones balance across threads).
pub(super) const BAND_ROWS: usize = 4;

/// Pixels `Tracer::shade_traced` traces before writing them (64 work items): its results
/// held at once stay about 4 MB whatever the image.
pub(super) const SHADE_BATCH: usize = 64 * CHUNK;

impl Tracer<'_> {
    /// One sample's radiance (the background on a miss), its hit and the lights it found
    /// blocked.
    #[inline]
    pub(super) fn sample(&self, ray: &CameraRay, known: Known) -> (Vec3, Option<(Hit, Option<SurfacePoint>)>, u8) {
        let hit = self.accel.closest(ray.origin, ray.dir, 0.0, f32::INFINITY);
        self.sample_hit(ray, known, super::run_on::run_on(self.world, ray.origin, ray.dir, hit))
    }

    /// `sample` with `ray`'s closest hit `hit` already found.
    #[inline]
    pub(super) fn sample_hit(
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
    pub(super) fn trace_pixel(
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
    pub(super) fn render_all(&self, film: &mut Film, rays: &Rays, progress: &Progress) {
        self.render_rows(film, rays, progress, |_| true, |_| Known::NONE, None);
    }

    /// The pixels `pick` chooses, bands of `TILE` rows in parallel, in place, with what
    /// `known(i)` says of the lights of pixel `i`.
    pub(super) fn render_rows(
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
    pub(super) fn trace_packet(
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
    pub(super) fn closest_of(&self, packet: &[CameraRay; TileRow::PACKET], n: usize) -> [Option<Hit>; TileRow::PACKET] {
        let lanes: [(Vec3, Vec3); TileRow::PACKET] = packet.map(|r| (r.origin, r.dir));
        let hits = self.accel.closest4(&lanes[..n], 0.0, f32::INFINITY);
        // The lanes past `n` repeat the last ray and are not read.
        std::array::from_fn(|l| {
            if l < n { super::run_on::run_on(self.world, lanes[l].0, lanes[l].1, hits[l]) } else { hits[l] }
        })
    }

    /// The pixels of `list`, in parallel chunks, with what `known[k]` says of the lights of
    /// `list[k]`.
    pub(super) fn render_subset(
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
    /// film. No result buffer for the whole list (about 27 MB of fresh pages
    /// for venus_11k's 480K moved pixels at 1000 x 1000) and no copy out of it. The same pixels:
    /// each is traced as before, only stored at once.
    pub(super) fn render_subset_in_place(
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
    pub(super) fn trace_subset(
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
}

/// Pixel `i`'s centre hit as `film` holds it (one sample per pixel), for `KnownHits`.
#[inline]
pub(super) fn centre_hit(film: &Film, i: usize) -> Option<Option<Hit>> {
    let h = &film.hits[i];
    Some(h.is_hit().then_some(Hit { tri: h.tri, object: h.object, t: h.t, u: h.u, v: h.v }))
}
