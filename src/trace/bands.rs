//! The film split into bands of rows for parallel writes.

use super::*;

/// Pixels from which `write_subset` writes in parallel (smaller lists, such as
/// `shade_traced`'s batches, cost more in tasks than they gain).
pub(super) const PARALLEL_WRITE: usize = 1 << 16;

/// Stores `trace_subset`'s chunks for the pixels of `list` in `film`: bands of rows in
/// parallel when `list` is long and ascends (the re-trace's does), else in
/// turn.
pub(super) fn write_subset(film: &mut Film, list: &[u32], chunks: Vec<SubsetChunk>) {
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
pub(super) type FilmBand<'a> = (&'a mut [Vec4], &'a mut [PixelHit], &'a mut [u8], &'a mut [SampleHit]);

/// Calls `f(base, band)` for each band of `rows` rows of `film`, in parallel; `base` is the
/// band's first pixel.
pub(super) fn for_each_band<F>(film: &mut Film, rows: usize, f: F)
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
pub(super) fn for_each_band_of<F>(film: &mut Film, rows: usize, list: &[u32], f: F)
where
    F: Fn(usize, usize, usize, FilmBand<'_>) + Sync,
{
    for_each_band(film, rows, |base, band| {
        let first = list.partition_point(|&i| (i as usize) < base);
        let last = list.partition_point(|&i| (i as usize) < base + band.0.len());
        f(base, first, last, band);
    });
}
