//! Every value's range, checked once after the layers are merged; the error names the key.
//! A key's range is declared with it (`table`) and checked by `in_range`, with the message its
//! entry gives; the checks here are those of several keys, or of what a range cannot say
//! (a camera's angle, the Segment levels, the frame range), and the memory bound.

use std::path::PathBuf;

use super::range::Range;
use super::{CameraKind, Faceting, Settings};
use crate::error::{Error, Result, short_num as num, short_path};

/// How a key's declared range is checked.
#[derive(Clone, Copy, Debug)]
pub(super) enum Check {
    /// By `in_range`, with this message for a value outside it: `{v}` is the value, `{range}`
    /// the interval (`[0, 1]`), `{min}` and `{max}` its ends, `{max:e}` the end in exponent form.
    Message(&'static str),
    /// By hand in `Settings::validate`: the range alone does not say what is accepted.
    ByHand,
}

/// The message of most keys.
pub(super) const IN_RANGE: Check = Check::Message("{v} must be a number in {range}");

/// The numbers a settings value holds, for its range check: a number itself, each item of a
/// list or vector, none of a name, flag or path.
pub(crate) trait Numbers {
    fn numbers(&self, _out: &mut Vec<f64>) {}
}

macro_rules! numbers_as_f64 {
    ($($t:ty),*) => {$(
        impl Numbers for $t {
            fn numbers(&self, out: &mut Vec<f64>) {
                out.push(*self as f64);
            }
        }
    )*};
}
numbers_as_f64!(u32, u64, f32, f64);

impl Numbers for bool {}
impl Numbers for String {}
impl Numbers for PathBuf {}

impl<T: Numbers> Numbers for Option<T> {
    fn numbers(&self, out: &mut Vec<f64>) {
        if let Some(v) = self {
            v.numbers(out);
        }
    }
}

impl<T: Numbers, const N: usize> Numbers for [T; N] {
    fn numbers(&self, out: &mut Vec<f64>) {
        self.iter().for_each(|v| v.numbers(out));
    }
}

impl<T: Numbers> Numbers for Vec<T> {
    fn numbers(&self, out: &mut Vec<f64>) {
        self.iter().for_each(|v| v.numbers(out));
    }
}

/// Checks every number of `value` against `range` (none: nothing to check); the first one
/// outside it is an error naming `key`, worded by `check`.
pub(super) fn in_range(key: &'static str, value: &impl Numbers, range: Option<Range>, check: Check) -> Result<()> {
    let (Some(range), Check::Message(message)) = (range, check) else { return Ok(()) };
    let mut numbers = Vec::new();
    value.numbers(&mut numbers);
    match numbers.into_iter().find(|&v| !range.contains(v)) {
        None => Ok(()),
        Some(v) => {
            let max = range.max.unwrap_or(f64::INFINITY);
            let message = message
                .replace("{v}", &num(v))
                .replace("{range}", &range.to_string())
                .replace("{min}", &num(range.min))
                .replace("{max:e}", &format!("{max:e}"))
                .replace("{max}", &num(max));
            Err(Error::setting(key, message))
        }
    }
}

fn length(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Largest image side we accept, pixels.
pub const MAX_SIDE: u32 = 16384;
/// Largest image we accept, pixels (8K x 8K). Together with `MAX_SAMPLES` this bounds memory.
pub const MAX_PIXELS: u64 = 64 * 1024 * 1024;
/// Largest number of primary samples per image (pixels x spp). Each keeps a 12-byte hit
/// record for saliency and face counting: 256 M samples is about 3 GB.
pub const MAX_SAMPLES: u64 = 256 * 1024 * 1024;
/// Most facets a layout may have: facet ids fit the 16-bit `facet-ids` pass and PNG layouts
/// (`facets::MAX_FACETS`, checked equal where both are known, in `pipeline::params`).
pub const MAX_FACETS: u32 = 65536;
/// Most planes the planes faceting splits the canvas into (`facets::planes::MAX_PLANES`,
/// checked equal in `pipeline::params`): the outlines then cut them into at most a few times
/// as many facets, well within `MAX_FACETS`.
pub const MAX_PLANES: u32 = 4000;
/// Largest pixel distance (discontinuity, neighborhood, border and silhouette widths), pixels
/// at 1000 px: ten images wide. Larger values mean nothing more, and f32 casts of them overflow.
pub const MAX_PIXEL_DISTANCE: f64 = 10_000.0;
/// Largest weight of a Segment cue: the cues' squared distances stay finite in f32.
pub const MAX_WEIGHT: f64 = 1000.0;
/// Largest scene-units value (camera position, target, size, focus distance): 1e15, far beyond
/// any scene, so vector arithmetic in f64 never overflows.
pub const MAX_SCENE_VALUE: f64 = 1e15;
/// Largest exposure and background value.
pub const MAX_EXPOSURE: f64 = 1000.0;
/// Largest occlusion ratio of Patch faceting (eq 4.3): 1000 covers the image with one quad.
pub const MAX_OCCLUSION: f64 = 1000.0;
/// Most Segment levels, and most segments in a level: the normalized cut computes as many
/// eigenvectors as the largest level's segments over thousands of superpixels (time and memory
/// grow with their product; 500 takes about a minute at 1000 x 1000).
pub const MAX_SEGMENT_LEVELS: usize = 8;
pub const MAX_SEGMENTS: u32 = 500;
/// Most superpixels the normalized cut may group.
pub const MAX_SUPERPIXELS: u32 = 200_000;
/// The memory bound of a job (README "Limits"): its settings' estimated memory, without the
/// scene's own, may not exceed this. The estimate is bytes per pixel of every buffer the
/// stages it runs hold at their peak (`memory_estimate`, measured: `tests/memory_bound.rs`,
/// `scripts/memory_bound.sh`).
pub const MAX_JOB_MEMORY: u64 = 6 << 30;
/// Most Voronoi grid cells.
pub const MAX_GRID_CELLS: u32 = 1 << 20;

impl Settings {
    /// Bytes a job of these settings holds at its peak, besides the scene, an upper estimate:
    /// per pixel, the film (colour, hit and 12 bytes per sample) and the encoded image, plus
    /// the facet map, imprecision and painting buffers of a faceted render, plus the Segment
    /// features, superpixels and level labels. Measured at 4 Mpx: plain 70 + 12 (spp - 1)
    /// bytes a pixel, Voronoi 91, analytic (3 levels) 136, 8 levels 160; the estimate is 5-15%
    /// above each.
    pub fn memory_estimate(&self) -> u64 {
        let pixels = self.width as u64 * self.height as u64;
        let mut per_pixel = 72 + 12 * self.spp as u64;
        let loaded = self.facets.is_some();
        if self.faceting != Faceting::None || loaded {
            per_pixel += 28;
        }
        if self.faceting == Faceting::Segment && !loaded {
            per_pixel += 28 + 6 * self.segments.len() as u64;
        }
        // Planes: the density, the outline trace and the per-pixel plane labels (measured: a
        // `cubist facets` job at 1 Mpx peaks at 161 MB, 45 bytes a pixel above a render's).
        if self.faceting == Faceting::Planes && !loaded {
            per_pixel += 48;
        }
        pixels.saturating_mul(per_pixel).saturating_add(64 << 20)
    }

    /// Checks every value's range and the values that depend on each other; the error names
    /// the key. The declared ranges first (`check_ranges`, in `Settings` order), then the
    /// checks of several keys or of what a range cannot say, then the memory bound.
    pub fn validate(&self) -> Result<()> {
        let s = self;
        s.check_ranges()?;
        // The side at fault: the width unless only the height is.
        let side = |width_ok: bool| if width_ok { "height" } else { "width" };
        if s.width == 0 || s.height == 0 {
            return Err(Error::setting(side(s.width > 0), format!("image size {}x{} is empty", s.width, s.height)));
        }
        if s.width > MAX_SIDE || s.height > MAX_SIDE {
            return Err(Error::setting(
                side(s.width <= MAX_SIDE),
                format!("image size {}x{} exceeds the {MAX_SIDE} px limit per side", s.width, s.height),
            ));
        }
        let pixels = s.width as u64 * s.height as u64;
        if pixels > MAX_PIXELS {
            return Err(Error::setting(
                "width",
                format!("{}x{} = {pixels} pixels exceeds the memory bound of {MAX_PIXELS} pixels", s.width, s.height),
            ));
        }
        if pixels * s.spp as u64 > MAX_SAMPLES {
            return Err(Error::setting(
                "spp",
                format!(
                    "{pixels} pixels x {} spp exceeds the memory bound of {MAX_SAMPLES} samples (about 3 GB)",
                    s.spp
                ),
            ));
        }
        if let Some(a) = s.ambiguity {
            if !a.is_finite() {
                return Err(Error::setting("ambiguity", format!("{} must be a finite number of degrees", num(a))));
            }
            match s.camera {
                CameraKind::Planar if !(0.0..180.0).contains(&a) => {
                    return Err(Error::setting(
                        "ambiguity",
                        format!(
                            "{} deg is impossible for the planar camera: its convergence angle must be in [0, 180)",
                            num(a)
                        ),
                    ));
                }
                CameraKind::Perspective if !(a > 0.0 && a < 180.0) => {
                    return Err(Error::setting(
                        "ambiguity",
                        format!("{} deg is not a field of view: the perspective camera needs (0, 180)", num(a)),
                    ));
                }
                _ if !(0.0..=360.0).contains(&a) => {
                    return Err(Error::setting(
                        "ambiguity",
                        format!("{} deg is out of range: the convergence angle must be in [0, 360]", num(a)),
                    ));
                }
                _ => {}
            }
        }
        if let Some(u) = s.camera_up
            && !(length(u) > 1e-100)
        {
            return Err(Error::setting("camera_up", "must be a finite, non-zero vector"));
        }
        if let (Some(p), Some(t)) = (s.camera_position, s.camera_target) {
            let d = [t[0] - p[0], t[1] - p[1], t[2] - p[2]];
            let scale = p.iter().chain(&t).fold(1.0f64, |m, x| m.max(x.abs()));
            if !(length(d) > 1e-12 * scale) {
                return Err(Error::setting("camera_target", "coincides with camera_position: no view direction"));
            }
        }
        if s.segments.is_empty() || s.segments.contains(&0) {
            return Err(Error::setting("segments", "needs one or more levels, each of at least 1 segment"));
        }
        if s.segments.len() > MAX_SEGMENT_LEVELS || s.segments.iter().any(|&n| n > MAX_SEGMENTS) {
            return Err(Error::setting(
                "segments",
                format!("at most {MAX_SEGMENT_LEVELS} levels of at most {MAX_SEGMENTS} segments each"),
            ));
        }
        if s.thresholds.len() != s.segments.len() {
            return Err(Error::setting(
                "thresholds",
                format!("{} thresholds given for {} segment levels", s.thresholds.len(), s.segments.len()),
            ));
        }
        if s.colors == 1 {
            return Err(Error::setting("colors", "quantising to 1 colour leaves no image; use 0 (off) or >= 2"));
        }
        s.frame_range()?;
        if let Some(dir) = &s.saliency_cache
            && dir.exists()
            && !dir.is_dir()
        {
            return Err(Error::setting("saliency_cache", format!("{} is not a directory", short_path(dir))));
        }
        if s.faceting == Faceting::Constant && s.facet_map.is_none() && s.facets.is_none() {
            return Err(Error::setting("facet_map", "constant faceting needs a facet map image (--facet-map)"));
        }
        // Last: every value is in range, so the estimate is of a job that could run.
        let need = s.memory_estimate();
        if need > MAX_JOB_MEMORY {
            let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
            return Err(Error::setting(
                if s.spp > 1 { "spp" } else { "width" },
                format!(
                    "{}x{} at {} spp with these stages needs about {:.1} GiB, more than the {:.0} GiB memory bound: \
                     fewer pixels or samples per pixel (or fewer Segment levels)",
                    s.width,
                    s.height,
                    s.spp,
                    gib(need),
                    gib(MAX_JOB_MEMORY)
                ),
            ));
        }
        Ok(())
    }
}
