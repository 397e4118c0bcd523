//! Colour transfer (SPEC "Colour transfer", thesis 4.4): the output's pixels sorted by
//! luminance take the colours at the same quantile of a reference painting's pixels sorted
//! the same way. Built-in palettes are references too: luminance-ordered colour ramps written
//! for this project (no painting's pixels), so the look works with no painting at hand.
//!
//! The mapping is a stable function of the picture: luminance is keyed
//! against a robust top (`TOP_QUANTILE`), not the brightest pixel, and the contrast limit
//! bounds its slope (`rank_quantiles`), so the film's sampling differences are not amplified.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use super::effect::path_bytes;
use super::inputs::is_subject;
use super::ranks::{StableKeys, TOP_QUANTILE, luminance_quantile, rank_quantiles, rank_table};
use super::{Canvas, Effect, EffectParams, KEY_LEVELS, PaintContext, UNPAINTED, luminance};
use crate::error::{Error, Result};
use crate::scene::texture::srgb_to_linear;

/// The colour transfer's parameters: a built-in palette mapped onto the luminance ranks, or a
/// painting whose colours are mapped instead (`image` overrides `palette`); off with neither.
/// The painting's contents are not in its key (the caller keys them: `file_key`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PaletteParams {
    pub palette: Palette,
    #[serde(serialize_with = "path_bytes")]
    pub image: Option<std::path::PathBuf>,
    /// The ochre-grey palette's plane hues (`PlaneHues`).
    pub seed: u64,
    /// The share of its luminance the ground (background, open planes) is ranked at
    /// (`ColourTransfer::ranked_luminances`).
    pub ground_value: f64,
}

/// How far the ochre palette turns a plane at the canvas's edge towards its grey or green
/// (`PlaneHues`).
pub const PLANE_HUE_STRENGTH: f32 = 0.6;

impl EffectParams for PaletteParams {
    fn is_on(&self) -> bool {
        self.image.is_some() || ramp(self.palette).is_some()
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(match (&self.image, ramp(self.palette)) {
            (Some(path), _) => {
                Box::new(ColourTransfer { ground_value: self.ground_value as f32, ..ColourTransfer::from_image(path)? })
            }
            (None, Some(ramp)) => {
                let mut t =
                    ColourTransfer { ground_value: self.ground_value as f32, ..ColourTransfer::from_ramp(ramp) };
                // The ochre-grey palette of 1910-11 is not one hue: greys and greens too.
                if self.palette == Palette::OchreGrey {
                    t.hues = Some(PlaneHues { strength: PLANE_HUE_STRENGTH, seed: self.seed });
                }
                Box::new(t)
            }
            (None, None) => {
                return Err(Error::Internal("the palette effect built without a palette".into()));
            }
        })
    }
}

/// The built-in palettes: luminance-ordered colour ramps written for this project.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Palette {
    None,
    /// Picasso and Braque, 1910: umber, ochre, lead white.
    Ochre,
    /// Picasso and Braque, 1910-11: `OCHRE_GREY`'s umbers and ochres, turned plane by plane
    /// towards cool greys and grey-greens away from the composition's centre (`PlaneHues`).
    OchreGrey,
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

/// The ochre of 1910-11 held low and narrow (umber to a muted ochre, no cream: the lights of
/// the 1910 canvases are few), under the `OchreGrey` palette's cool edges.
pub const OCHRE_GREY: Ramp = Ramp {
    name: "ochre-grey",
    stops: &[
        (0.00, [0x18, 0x11, 0x0b]),
        (0.15, [0x33, 0x25, 0x18]),
        (0.40, [0x5c, 0x44, 0x29]),
        (0.65, [0x82, 0x66, 0x3e]),
        (0.86, [0xa8, 0x8c, 0x5e]),
        (1.00, [0xcc, 0xb8, 0x8a]),
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
        Palette::OchreGrey => Some(&OCHRE_GREY),
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
    /// Cool greys and grey-greens among the ochres, plane by plane (`PlaneHues`); None: the
    /// reference's colours only.
    pub hues: Option<PlaneHues>,
    /// The share of its luminance the ground (background, open planes) is ranked at
    /// (`ranked_luminances`); 1: ranked as painted.
    pub ground_value: f32,
}

/// A narrow palette that is not one hue: warm ochres at the composition's lit centre, cooler
/// greys and grey-greens towards its edges (as the 1910-11 canvases cool their peripheries),
/// each plane at the value the reference gives it, so value carries the form. A plane's hue
/// is taken at its own centre (one hue a plane) with a small seeded turn of its own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneHues {
    /// How far a plane at the canvas's edge goes towards its cool hue, in [0, 1].
    pub strength: f32,
    pub seed: u64,
}

/// The share of the planes whose cool hue is a grey-green rather than a grey.
pub const GREY_GREEN_SHARE: f64 = 0.35;
/// The cool hues, as linear RGB directions of luminance 1.
const COOL_GREY: [f32; 3] = [0.93, 1.0, 1.1];
const GREY_GREEN: [f32; 3] = [0.92, 1.04, 0.86];
const HUES_SALT: u64 = 0x6875_6573_3130_3131; // "hues1011"

impl PlaneHues {
    /// The colour `c` of a pixel of plane `facet`, whose centre lies `r` from the
    /// composition's centre (`plane_light::Oval::r`), turned towards the plane's cool hue at
    /// the same luminance: not at all at the centre, `strength` at the edges.
    pub fn turn(&self, c: Vec3, facet: u32, r: f32) -> Vec3 {
        let u = crate::util::rng::unit_f64(crate::util::rng::splitmix64(
            crate::util::rng::sub_seed(self.seed, HUES_SALT) ^ crate::util::rng::splitmix64(facet as u64),
        ));
        let hue = if u < GREY_GREEN_SHARE { Vec3::from(GREY_GREEN) } else { Vec3::from(COOL_GREY) };
        let t = super::planes::smoothstep(0.25, 0.95, r) * (0.75 + 0.5 * u as f32);
        let target = hue / luminance(hue) * luminance(c);
        c.lerp(target, (self.strength * t).min(1.0))
    }
}

impl ColourTransfer {
    /// A built-in palette: its ramp sampled at `LEVELS` quantiles.
    pub fn from_ramp(ramp: &Ramp) -> ColourTransfer {
        let levels = (0..LEVELS).map(|k| ramp.at((k as f32 + 0.5) / LEVELS as f32)).collect();
        ColourTransfer { levels, contrast_limit: CONTRAST_LIMIT, hues: None, ground_value: 1.0 }
    }

    /// A painting (PNG or JPEG, any size); fully transparent pixels are not part of it.
    pub fn from_image(path: &Path) -> Result<ColourTransfer> {
        // Bounded: a regular file, its size checked before decoding.
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
        Ok(ColourTransfer { levels, contrast_limit: CONTRAST_LIMIT, hues: None, ground_value: 1.0 })
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
    /// the contrast-limited histogram of `StableKeys` (luminance against a robust top, not
    /// the brightest pixel); pixels tied on luminance share their group's middle rank.
    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let lum = self.ranked_luminances(canvas, ctx);
        let levels = &self.levels;
        let hues = self.hues.filter(|_| ctx.facets.is_some());
        // Each plane's distance from the composition's centre, at the plane's own centre.
        let plane_r: Vec<f32> = match hues {
            // A sequence's planes (the layout's, moved with facets that follow): a plane the
            // subject covers part of keeps its centre, hence its hue.
            Some(h) if ctx.in_sequence() => {
                let (w, h_px) = (canvas.width as usize, canvas.height as usize);
                let oval = ctx.oval(w, h_px);
                ctx.planes(canvas.width, w * h_px, h.seed).iter().map(|p| oval.r(p.centre)).collect()
            }
            Some(_) => {
                let (w, h) = (canvas.width as usize, canvas.height as usize);
                let oval = ctx.oval(w, h);
                let mut sums = vec![(0.0f64, 0.0f64, 0u64); ctx.facet_count()];
                for i in 0..w * h {
                    if let Some(s) = sums.get_mut(ctx.facet(i) as usize) {
                        *s = (s.0 + (i % w) as f64, s.1 + (i / w) as f64, s.2 + 1);
                    }
                }
                sums.iter()
                    .map(|&(x, y, n)| {
                        let n = n.max(1) as f64;
                        oval.r(glam::Vec2::new((x / n) as f32 + 0.5, (y / n) as f32 + 0.5))
                    })
                    .collect()
            }
            None => Vec::new(),
        };
        let turned = |c: Vec3, i: usize| {
            let f = ctx.facet(i);
            hues.map_or(c, |h| h.turn(c, f, plane_r.get(f as usize).copied().unwrap_or(0.0)))
        };
        // Animation frames: the sequence's one palette table (a still background keeps its
        // colours while the subject moves).
        if let Some(key) = ctx.palette_key() {
            canvas.px.par_iter_mut().zip(&lum).enumerate().for_each(|(i, (p, &l))| {
                if let Some(k) = key.level(l) {
                    *p = turned(levels[(k as usize).min(levels.len() - 1)], i).extend(p.w);
                }
            });
            return Ok(());
        }
        // `level_indices`, each pixel's level written as it is looked up (no index buffer).
        let Some((keys, table)) = self.keys_and_levels(&lum) else { return Ok(()) };
        canvas.px.par_iter_mut().zip(&keys.keys).enumerate().for_each(|(i, (p, &k))| {
            if k != UNPAINTED {
                *p = turned(levels[table[k as usize] as usize], i).extend(p.w);
            }
        });
        Ok(())
    }

    fn palette_key(&self, canvas: &Canvas<'_>, ctx: &PaintContext) -> Option<PaletteKey> {
        let lum = self.ranked_luminances(canvas, ctx);
        let top = luminance_quantile(&lum, TOP_QUANTILE);
        let keys = StableKeys::from_luminances(&lum);
        if keys.total == 0 {
            return None;
        }
        let n = self.levels.len();
        let levels = rank_quantiles(&keys.histogram, keys.total, self.contrast_limit)
            .iter()
            .map(|q| ((q * n as f64) as usize).min(n - 1) as u32)
            .collect();
        Some(PaletteKey { scale: if top > 0.0 && top.is_finite() { 1.0 / top } else { 0.0 }, levels })
    }
}

/// Each pixel's luminance, -1 where the effects do not paint.
fn painted_luminances(canvas: &Canvas<'_>) -> Vec<f32> {
    let coverage = super::Coverage(canvas.coverage.as_deref());
    canvas
        .px
        .par_iter()
        .enumerate()
        .map(|(i, p)| if coverage.is_painted(i) { luminance(p.truncate()).max(0.0) } else { -1.0 })
        .collect()
}

/// A colour transfer's luminance-to-level mapping, decided on one picture and held for the
/// frames of a sequence: each key (as `StableKeys` makes them, against the picture's robust
/// top) takes its `rank_quantiles` quantile's level, keys absent from that picture included
/// (the quantiles are non-decreasing), so a frame's pixel of the same luminance always takes
/// the same colour.
#[derive(Clone, Debug, PartialEq)]
pub struct PaletteKey {
    /// 1 / the picture's robust top luminance.
    scale: f32,
    /// The level of every key.
    levels: Vec<u32>,
}

impl PaletteKey {
    /// The level of a pixel of luminance `l` (None: not painted, `l` < 0).
    pub fn level(&self, l: f32) -> Option<u32> {
        if l < 0.0 {
            return None;
        }
        let last = (KEY_LEVELS - 1) as f32;
        let k = ((l * self.scale).min(1.0).sqrt() * last + 0.5) as usize;
        Some(self.levels[k.min(self.levels.len() - 1)])
    }
}

impl ColourTransfer {
    /// Each pixel's luminance as the palette ranks it (-1 where the effects do not paint): the
    /// ground's (the background and the planes open across the outline, `is_subject`) times
    /// `ground_value`. Below 1 the subject takes the upper, lighter part of the palette and
    /// the ground the lower, so a dark part of the subject (a brown bowl, a wooden handle)
    /// stands out of a ground of its own value, as the 1910 canvases gather the light on the
    /// figure. A transparent canvas paints no background: only its open planes are ground.
    fn ranked_luminances(&self, canvas: &Canvas<'_>, ctx: &PaintContext) -> Vec<f32> {
        let mut lum = painted_luminances(canvas);
        if self.ground_value < 1.0 {
            let regions = ctx.regions(lum.len());
            lum.par_iter_mut().zip(regions.par_iter()).for_each(|(l, &r)| {
                if *l > 0.0 && !is_subject(r) {
                    *l *= self.ground_value;
                }
            });
        }
        lum
    }

    /// The level (index into `levels`) each pixel takes, from the pixels' luminances
    /// (negative = not painted: `UNPAINTED`).
    pub fn level_indices(&self, lum: &[f32]) -> Vec<u32> {
        let Some((keys, table)) = self.keys_and_levels(lum) else { return vec![UNPAINTED; lum.len()] };
        keys.keys.par_iter().map(|&k| if k == UNPAINTED { UNPAINTED } else { table[k as usize] }).collect()
    }

    /// The pixels' `StableKeys` and each key's level (`rank_table`); None when no pixel is
    /// painted.
    fn keys_and_levels(&self, lum: &[f32]) -> Option<(StableKeys, Vec<u32>)> {
        let keys = StableKeys::from_luminances(lum);
        if keys.total == 0 {
            return None;
        }
        let table = rank_table(&keys.histogram, keys.total, self.contrast_limit, self.levels.len());
        Some((keys, table))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::{splitmix64, unit_f64};

    /// Deterministic pseudo-random luminances in [lo, hi).
    fn luminances(n: usize, seed: u64, lo: f32, hi: f32) -> Vec<f32> {
        (0..n as u64).map(|i| lo + (hi - lo) * unit_f64(splitmix64(seed ^ splitmix64(i))) as f32).collect()
    }

    #[test]
    fn brighter_pixels_never_take_darker_levels() {
        let t = ColourTransfer::from_ramp(&OCHRE);
        let lum = luminances(20_000, 5, 0.0, 1.3);
        let idx = t.level_indices(&lum);
        let mut order: Vec<usize> = (0..lum.len()).collect();
        order.sort_by(|a, b| lum[*a].total_cmp(&lum[*b]));
        assert!(order.windows(2).all(|w| idx[w[0]] <= idx[w[1]]));
    }

    /// The picture's mapping must not hang on its brightest pixel: a glint
    /// twice as bright, or gone, leaves every other pixel's level where it was.
    #[test]
    fn one_glint_does_not_move_the_other_pixels() {
        let t = ColourTransfer::from_ramp(&OCHRE);
        // A picture of mostly mid-tones (flat areas: spikes the contrast limit clips) and one glint.
        let mut lum: Vec<f32> = luminances(40_000, 9, 0.05, 0.6);
        for (i, l) in lum.iter_mut().enumerate().take(20_000) {
            *l = [0.2, 0.35, 0.5][i % 3];
        }
        lum[123] = 0.9;
        let a = t.level_indices(&lum);
        for glint in [1.8, 0.61] {
            let mut other = lum.clone();
            other[123] = glint;
            let b = t.level_indices(&other);
            let moved = a.iter().zip(&b).enumerate().filter(|(i, (x, y))| *i != 123 && x != y).count();
            assert_eq!(moved, 0, "glint at {glint}: {moved} other pixels changed level");
        }
    }

    /// Small noise on every pixel moves levels by little: the slope bound, end to end.
    #[test]
    fn noise_moves_levels_in_proportion() {
        let t = ColourTransfer::from_ramp(&OCHRE);
        let mut lum: Vec<f32> = luminances(60_000, 11, 0.02, 0.7);
        for (i, l) in lum.iter_mut().enumerate().take(30_000) {
            *l = 0.3 + 0.01 * (i % 7) as f32;
        }
        let a = t.level_indices(&lum);
        let noisy: Vec<f32> = lum
            .iter()
            .enumerate()
            .map(|(i, l)| l * (1.0 + 2e-3 * (2.0 * unit_f64(splitmix64(i as u64)) as f32 - 1.0)))
            .collect();
        let b = t.level_indices(&noisy);
        let worst = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
        // +-0.2% luminance noise is +-0.1% of the key (sqrt), 0.07% of the key range here; at
        // slope (limit + 1) that is 0.35% of the quantile range, under 4 of 1024 levels. The
        // flat half of the picture (seven spikes the noise widens) must not add to it: without
        // the smoothing, the clip's spread excess moved every pixel by up to 22 levels.
        assert!(worst <= 4, "a pixel moved {worst} levels");
    }

    #[test]
    fn level_indices_are_the_same_on_any_thread_count() {
        let t = ColourTransfer::from_ramp(&GREY);
        let mut lum = luminances(200_003, 13, 0.0, 2.0);
        lum[17] = -1.0;
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| t.level_indices(&lum))
        };
        let one = run(1);
        assert_eq!(one[17], UNPAINTED);
        for threads in [2, 5] {
            assert!(run(threads) == one, "{threads} threads differ from 1");
        }
    }
}
