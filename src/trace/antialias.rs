//! Adaptive anti-aliasing: which pixels get `spp` samples (their facet neighbours disagree)
//! and their supersampling.

use super::*;

impl Tracer<'_> {
    /// The colour of pixel `i` from `spp` stratified samples (alpha: the fraction that hit),
    /// with the shadow rays `occlusion` answers left out. `centre` (only at 4 spp): the colour
    /// (and coverage) of the pixel's centre sample, already traced, taken as one of the 4
    /// samples with 3 new ones around it (`centre_rook_offset`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn supersample(
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

/// What anti-aliasing takes as known of pixel `i`'s lights
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
/// agree on (cast shadow rays only where a light is partly occluded).
pub(super) fn agreed_occlusion(film: &Film, facets: &[u32], i: usize) -> Known {
    // `facet_neighbourhood`'s pixels, gathered by plain loops (its chain of iterators cost
    // more than `agree` itself; `agree` does not depend on their order).
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
    // they read 8 bytes, not a 32-byte hit and a colour.
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

/// The 8-neighbours of pixel `i` in the same facet, and `i` itself: what `agreed_occlusion`
/// and `pixels_to_refine` compare (written as loops there; the tests hold them to this).
#[cfg(test)]
pub(super) fn facet_neighbourhood(
    width: usize,
    height: usize,
    facets: &[u32],
    i: usize,
) -> impl Iterator<Item = usize> + '_ {
    let (x, y) = ((i % width) as isize, (i / width) as isize);
    let f = facets[i];
    (-1..=1isize)
        .flat_map(move |dy| (-1..=1isize).map(move |dx| (x + dx, y + dy)))
        .filter(move |&(nx, ny)| nx >= 0 && ny >= 0 && (nx as usize) < width && (ny as usize) < height)
        .map(move |(nx, ny)| ny as usize * width + nx as usize)
        .filter(move |&j| facets[j] == f)
}
