//! Colour transfer (SPEC "Colour transfer", thesis 4.4): the output's pixels sorted by
//! luminance take the colours at the same quantile of a reference painting's pixels sorted
//! the same way. Built-in palettes are references too: luminance-ordered colour ramps written
//! for this project (no painting's pixels), so the look works with no painting at hand.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use super::{Canvas, Effect, LuminanceKeys, PaintContext, UNPAINTED, luminance};
use crate::error::{Error, Result};
use crate::scene::texture::srgb_to_linear;

/// The built-in palettes: luminance-ordered colour ramps written for this project.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Palette {
    None,
    /// Picasso and Braque, 1910: umber, ochre, lead white.
    Ochre,
    /// Grisaille, 1911: warm blacks, brownish and cool greys.
    Grey,
    /// Picasso's blue period: Prussian blue to pale blue-grey.
    BluePeriod,
    /// Braque, 1908-09: olive and earth greens to pale ochre.
    Olive,
}

/// Number of quantile levels a reference is reduced to.
pub const LEVELS: usize = 1024;
/// References larger than this are subsampled (every k-th pixel) before sorting.
const MAX_REFERENCE_PIXELS: usize = 1 << 22;

/// A built-in palette: sRGB colours at quantile positions in [0, 1], darkest first. The
/// positions carry the tonal distribution of the paintings they evoke (analytical cubist
/// canvases are mostly mid-tones with few deep darks and few lights).
pub struct Ramp {
    pub name: &'static str,
    pub stops: &'static [(f32, [u8; 3])],
}

/// Picasso and Braque, 1910: umber darks, ochre mid-tones, lead-white lights.
pub const OCHRE: Ramp = Ramp {
    name: "ochre",
    stops: &[
        (0.00, [0x1c, 0x14, 0x0d]),
        (0.12, [0x3d, 0x2c, 0x1c]),
        (0.35, [0x7a, 0x5a, 0x36]),
        (0.60, [0xa8, 0x84, 0x4f]),
        (0.82, [0xc9, 0xad, 0x78]),
        (1.00, [0xeb, 0xdc, 0xb4]),
    ],
};

/// Grisaille, 1911: warm blacks through brownish and cool greys to off-white.
pub const GREY: Ramp = Ramp {
    name: "grey",
    stops: &[
        (0.00, [0x16, 0x14, 0x0f]),
        (0.20, [0x3b, 0x38, 0x33]),
        (0.50, [0x76, 0x70, 0x69]),
        (0.80, [0xb1, 0xac, 0xa2]),
        (1.00, [0xe4, 0xe1, 0xd8]),
    ],
};

/// Picasso's blue period: Prussian-blue darks, slate mid-tones, pale blue-grey lights.
pub const BLUE_PERIOD: Ramp = Ramp {
    name: "blue-period",
    stops: &[
        (0.00, [0x0b, 0x10, 0x20]),
        (0.20, [0x1c, 0x2c, 0x4c]),
        (0.45, [0x35, 0x50, 0x7a]),
        (0.70, [0x6b, 0x86, 0xa3]),
        (0.90, [0xa9, 0xbc, 0xcb]),
        (1.00, [0xdd, 0xe4, 0xe6]),
    ],
};

/// Braque, 1908-09: olive and earth greens warming to pale ochre.
pub const OLIVE: Ramp = Ramp {
    name: "olive",
    stops: &[
        (0.00, [0x15, 0x17, 0x10]),
        (0.18, [0x33, 0x36, 0x1f]),
        (0.42, [0x5f, 0x63, 0x38]),
        (0.65, [0x8f, 0x8a, 0x55]),
        (0.85, [0xbc, 0xb1, 0x7f]),
        (1.00, [0xe2, 0xd9, 0xb0]),
    ],
};

/// The ramp of a built-in palette; None for `Palette::None`.
pub fn ramp(palette: Palette) -> Option<&'static Ramp> {
    match palette {
        Palette::None => None,
        Palette::Ochre => Some(&OCHRE),
        Palette::Grey => Some(&GREY),
        Palette::BluePeriod => Some(&BLUE_PERIOD),
        Palette::Olive => Some(&OLIVE),
    }
}

fn srgb8_to_linear(c: [u8; 3]) -> Vec3 {
    Vec3::new(
        srgb_to_linear(c[0] as f32 / 255.0),
        srgb_to_linear(c[1] as f32 / 255.0),
        srgb_to_linear(c[2] as f32 / 255.0),
    )
}

impl Ramp {
    /// The ramp's colour at quantile q in [0, 1], interpolated in linear RGB (luminance is
    /// linear in it, so a ramp with increasing stops increases everywhere).
    pub fn at(&self, q: f32) -> Vec3 {
        let s = self.stops;
        let q = q.clamp(0.0, 1.0);
        let k = s.iter().position(|(p, _)| *p >= q).unwrap_or(s.len() - 1);
        if k == 0 {
            return srgb8_to_linear(s[0].1);
        }
        let ((p0, c0), (p1, c1)) = (s[k - 1], s[k]);
        let t = if p1 > p0 { (q - p0) / (p1 - p0) } else { 1.0 };
        srgb8_to_linear(c0).lerp(srgb8_to_linear(c1), t)
    }
}

/// Default contrast limit of the rank mapping (see `ColourTransfer::contrast_limit`).
pub const CONTRAST_LIMIT: f64 = 4.0;

/// Maps luminance ranks onto a reference's colours.
pub struct ColourTransfer {
    /// Reference colours (linear RGB) at evenly spaced quantiles, luminance non-decreasing.
    levels: Vec<Vec3>,
    /// Largest slope of the rank mapping relative to a mapping linear in the luminance key.
    /// Plain ranks (`f64::INFINITY`, the SPEC's literal rule) turn a large flat area (the
    /// background, a facet) into one spike of the histogram, so an imperceptible step inside it
    /// (a gradient's tail, a border's falloff) jumps across a wide span of the reference: hard
    /// edges out of nothing. Clipping the histogram at `contrast_limit` x its uniform height
    /// and spreading the excess evenly (global contrast-limited equalisation, Pizer et al.
    /// 1987) bounds that amplification and keeps the mapping monotone.
    pub contrast_limit: f64,
}

impl ColourTransfer {
    /// A built-in palette: its ramp sampled at `LEVELS` quantiles.
    pub fn from_ramp(ramp: &Ramp) -> ColourTransfer {
        let levels = (0..LEVELS).map(|k| ramp.at((k as f32 + 0.5) / LEVELS as f32)).collect();
        ColourTransfer { levels, contrast_limit: CONTRAST_LIMIT }
    }

    /// A painting (PNG or JPEG, any size); fully transparent pixels are not part of it.
    pub fn from_image(path: &Path) -> Result<ColourTransfer> {
        // Bounded (issue 18): a regular file, its size checked before decoding.
        let bytes = crate::util::files::read_bounded(path, crate::util::limits::MAX_IMAGE_FILE)
            .map_err(|m| Error::input(path, format!("the palette image: {m}")))?;
        let img = crate::util::files::decode_image(&bytes, crate::util::limits::MAX_IMAGE_PIXELS)
            .map_err(|m| Error::input(path, format!("the palette image: {m}")))?
            .to_rgba8();
        let lut: Vec<f32> = (0..256).map(|v| srgb_to_linear(v as f32 / 255.0)).collect();
        let colours: Vec<Vec3> = img
            .pixels()
            .filter(|p| p.0[3] >= 128)
            .map(|p| Vec3::new(lut[p.0[0] as usize], lut[p.0[1] as usize], lut[p.0[2] as usize]))
            .collect();
        ColourTransfer::from_colours(&colours).map_err(|_| Error::input(path, "the palette image has no opaque pixel"))
    }

    /// A reference given as its pixels' linear colours (any number, any order), sorted by
    /// luminance (ties by position: deterministic) and reduced to `LEVELS` quantile levels by
    /// `choose_levels`: every colour the transfer paints is a colour of the reference.
    pub fn from_colours(colours: &[Vec3]) -> Result<ColourTransfer> {
        if colours.is_empty() {
            return Err(Error::setting("palette_image", "the reference has no pixel"));
        }
        let stride = colours.len().div_ceil(MAX_REFERENCE_PIXELS);
        let mut order: Vec<u64> = colours
            .iter()
            .enumerate()
            .step_by(stride)
            .map(|(i, c)| {
                // Non-negative floats order like their bits (and -0.0 must not sort last).
                let l = luminance(*c);
                let l = if l > 0.0 { l } else { 0.0 };
                ((l.to_bits() as u64) << 32) | i as u64
            })
            .collect();
        order.par_sort_unstable();
        let sorted: Vec<Vec3> = order.iter().map(|k| colours[(*k & 0xffff_ffff) as usize]).collect();
        let levels = choose_levels(&sorted, LEVELS);
        Ok(ColourTransfer { levels, contrast_limit: CONTRAST_LIMIT })
    }

    /// The reference's colours, darkest first.
    pub fn levels(&self) -> &[Vec3] {
        &self.levels
    }
}

impl Effect for ColourTransfer {
    fn name(&self) -> &'static str {
        "palette"
    }

    /// Pixel of rank k among N takes the level at quantile (k + 1/2) / N, ranks counted in
    /// the contrast-limited histogram; pixels tied on luminance share their group's middle
    /// rank.
    fn apply(&self, canvas: &mut Canvas<'_>, _ctx: &PaintContext) -> Result<()> {
        let keys = LuminanceKeys::new(canvas);
        if keys.total == 0 {
            return Ok(());
        }
        let hist = clipped_histogram(&keys.histogram, keys.total, self.contrast_limit);
        let n: f64 = hist.iter().sum();
        let l = self.levels.len();
        let mut table = vec![0u32; hist.len()];
        let mut before = 0.0f64;
        for ((t, &count), &h) in table.iter_mut().zip(&keys.histogram).zip(&hist) {
            if count > 0 {
                let q = (before + h * 0.5) / n;
                *t = ((q * l as f64) as usize).min(l - 1) as u32;
            }
            before += h;
        }
        let levels = &self.levels;
        canvas.px.par_iter_mut().zip(&keys.keys).for_each(|(p, k)| {
            if *k != UNPAINTED {
                *p = levels[table[*k as usize] as usize].extend(p.w);
            }
        });
        Ok(())
    }
}

/// Candidate reference pixels per level, spread over the bins within `SPAN` x the number of
/// levels on either side.
const CANDIDATES: usize = 24;
const SPAN: f64 = 1.0 / 128.0;
/// Levels on either side whose mean colour a level aims at, as a fraction of the levels.
const WINDOW: f64 = 1.0 / 32.0;
/// Weight of hue continuity between neighbouring levels against closeness to the local mean.
const CONTINUITY: f32 = 24.0;

/// Reduces reference colours sorted by luminance to at most `count` levels, one per quantile
/// bin, each a pixel of the reference. A painting's pixels of one luminance often hold several
/// hues (ochre and blue-grey of equal value); picking each bin's pixel independently flips
/// between them from level to level, which paints stripes across smooth shading. So the
/// levels are chosen together: among `CANDIDATES` pixels spread over the bins within `SPAN`
/// of each bin, the path that minimises the distance to the local mean colour (bins within
/// `WINDOW`) plus `CONTINUITY` x the distance to the previous level (Viterbi; distances in a
/// square-root, roughly perceptual, space), never stepping down in luminance. Keeping
/// candidate j at every level is always allowed (the windows slide forward), so a path exists.
pub fn choose_levels(sorted: &[Vec3], count: usize) -> Vec<Vec3> {
    let m = sorted.len();
    let bins = m.min(count);
    let p = |c: Vec3| c.max(Vec3::ZERO).powf(0.5);
    let mut prefix = Vec::with_capacity(m + 1);
    prefix.push(glam::DVec3::ZERO);
    for c in sorted {
        let last = *prefix.last().unwrap();
        prefix.push(last + p(*c).as_dvec3());
    }
    let range = |b: usize| (b * m / bins, (b + 1) * m / bins);
    let (span, window) = ((SPAN * bins as f64) as usize, (WINDOW * bins as f64) as usize);
    let n = m.min(CANDIDATES);
    let candidates: Vec<Vec<Vec3>> = (0..bins)
        .map(|b| {
            let (lo, _) = range(b.saturating_sub(span));
            let (_, hi) = range((b + span).min(bins - 1));
            (0..n).map(|j| sorted[lo + (2 * j + 1) * (hi - lo) / (2 * n)]).collect()
        })
        .collect();
    let targets: Vec<Vec3> = (0..bins)
        .map(|b| {
            let (lo, _) = range(b.saturating_sub(window));
            let (_, hi) = range((b + window).min(bins - 1));
            ((prefix[hi] - prefix[lo]) / (hi - lo) as f64).as_vec3()
        })
        .collect();
    // Viterbi: cost[j] of the best path ending at candidate j of the current bin.
    let mut back: Vec<Vec<u8>> = Vec::with_capacity(bins);
    let mut cost: Vec<f32> = candidates[0].iter().map(|c| (p(*c) - targets[0]).length_squared()).collect();
    back.push(vec![0; cost.len()]);
    for b in 1..bins {
        let (prev, cur) = (&candidates[b - 1], &candidates[b]);
        let mut next = Vec::with_capacity(cur.len());
        let mut from = Vec::with_capacity(cur.len());
        for c in cur {
            let data = (p(*c) - targets[b]).length_squared();
            let (best, k) = prev
                .iter()
                .zip(&cost)
                .enumerate()
                .filter(|(_, (q, _))| luminance(**q) <= luminance(*c))
                .map(|(k, (q, cq))| (cq + CONTINUITY * (p(*c) - p(*q)).length_squared(), k))
                .fold((f32::INFINITY, 0), |a, x| if x.0 < a.0 { x } else { a });
            next.push(best + data);
            from.push(k as u8);
        }
        cost = next;
        back.push(from);
    }
    let mut j = cost.iter().enumerate().fold((f32::INFINITY, 0), |a, (k, c)| if *c < a.0 { (*c, k) } else { a }).1;
    let mut levels = vec![Vec3::ZERO; bins];
    for b in (0..bins).rev() {
        levels[b] = candidates[b][j];
        j = back[b][j] as usize;
    }
    levels
}

/// The histogram clipped at `limit` x the uniform height, the excess spread evenly over every
/// key (one pass). An infinite limit returns the counts as they are.
pub fn clipped_histogram(histogram: &[u32], total: u64, limit: f64) -> Vec<f64> {
    let cap = limit * total as f64 / histogram.len() as f64;
    if !cap.is_finite() {
        return histogram.iter().map(|&c| c as f64).collect();
    }
    let excess: f64 = histogram.iter().map(|&c| (c as f64 - cap).max(0.0)).sum();
    let share = excess / histogram.len() as f64;
    histogram.iter().map(|&c| (c as f64).min(cap) + share).collect()
}
