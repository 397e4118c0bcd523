//! Every value's range, checked once after the layers are merged; the error names the key.

use super::{CameraKind, Faceting, Settings};
use crate::error::{Error, Result};

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

impl Settings {
    /// Checks every value's range; the error names the key.
    pub fn validate(&self) -> Result<()> {
        let s = self;
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
        if s.spp == 0 {
            return Err(Error::setting("spp", "must be at least 1"));
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
        if !(0.0..=1.0).contains(&s.aa_threshold) {
            return Err(Error::setting("aa_threshold", "must be in [0, 1] (an sRGB difference; 0 = every pixel)"));
        }
        if let Some(a) = s.ambiguity {
            if !a.is_finite() {
                return Err(Error::setting("ambiguity", "must be a finite number of degrees"));
            }
            match s.camera {
                CameraKind::Planar if !(0.0..180.0).contains(&a) => {
                    return Err(Error::setting(
                        "ambiguity",
                        format!(
                            "{a} deg is impossible for the planar camera: its convergence angle must be in [0, 180)"
                        ),
                    ));
                }
                CameraKind::Perspective if !(a > 0.0 && a < 180.0) => {
                    return Err(Error::setting(
                        "ambiguity",
                        format!("{a} deg is not a field of view: the perspective camera needs (0, 180)"),
                    ));
                }
                _ if !(0.0..=360.0).contains(&a) => {
                    return Err(Error::setting(
                        "ambiguity",
                        format!("{a} deg is out of range: the convergence angle must be in [0, 360]"),
                    ));
                }
                _ => {}
            }
        }
        if let Some(f) = s.focus_distance
            && !(f.is_finite() && f > 0.0)
        {
            return Err(Error::setting("focus_distance", format!("{f} must be a positive distance")));
        }
        if let Some(c) = s.camera_size
            && !(c.is_finite() && c > 0.0)
        {
            return Err(Error::setting("camera_size", format!("{c} must be a positive size")));
        }
        if let Some(f) = s.fill
            && !(f.is_finite() && f > 0.0 && f <= 1.0)
        {
            return Err(Error::setting("fill", format!("{f} must be in (0, 1]")));
        }
        for (key, v) in [("camera_position", s.camera_position), ("camera_target", s.camera_target)] {
            if let Some(v) = v
                && v.iter().any(|x| !x.is_finite())
            {
                return Err(Error::setting(key, "must be three finite numbers"));
            }
        }
        if let Some(u) = s.camera_up
            && (u.iter().any(|x| !x.is_finite()) || u.iter().all(|x| *x == 0.0))
        {
            return Err(Error::setting("camera_up", "must be a finite, non-zero vector"));
        }
        if let (Some(p), Some(t)) = (s.camera_position, s.camera_target)
            && p == t
        {
            return Err(Error::setting("camera_target", "coincides with camera_position: no view direction"));
        }
        if s.background.iter().any(|c| !c.is_finite() || *c < 0.0) {
            return Err(Error::setting("background", "must be three finite, non-negative numbers"));
        }
        if !(s.exposure.is_finite() && s.exposure >= 0.0) {
            return Err(Error::setting("exposure", "must be a finite, non-negative number"));
        }
        let nonneg = |key: &'static str, v: f64| -> Result<()> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::setting(key, format!("{v} must be a finite number >= 0")))
            }
        };
        let unit = |key: &'static str, v: f64| -> Result<()> {
            if (0.0..=1.0).contains(&v) { Ok(()) } else { Err(Error::setting(key, format!("{v} must be in [0, 1]"))) }
        };
        nonneg("discontinuity", s.discontinuity)?;
        nonneg("neighborhood", s.neighborhood)?;
        nonneg("border_width", s.border_width)?;
        nonneg("silhouette_width", s.silhouette_width)?;
        unit("border_strength", s.border_strength)?;
        unit("silhouette_strength", s.silhouette_strength)?;
        unit("gradients", s.gradients)?;
        unit("chiaroscuro", s.chiaroscuro)?;
        if !(s.facet_fov.is_finite() && (0.0..180.0).contains(&s.facet_fov)) {
            return Err(Error::setting("facet_fov", format!("{} must be in [0, 180) degrees", s.facet_fov)));
        }
        if s.facet_count == 0 || s.facet_count > MAX_FACETS {
            return Err(Error::setting("facet_count", format!("must be in 1..={}", MAX_FACETS)));
        }
        if s.grid_cells == 0 {
            return Err(Error::setting("grid_cells", "must be at least 1"));
        }
        if s.patch_count == 0 || s.patch_count > MAX_FACETS {
            return Err(Error::setting("patch_count", format!("must be in 1..={}", MAX_FACETS)));
        }
        if !(s.occlusion.is_finite() && s.occlusion > 0.0) {
            return Err(Error::setting("occlusion", "must be a positive number"));
        }
        if s.segments.is_empty() || s.segments.contains(&0) {
            return Err(Error::setting("segments", "needs one or more levels, each of at least 1 segment"));
        }
        if s.thresholds.len() != s.segments.len() {
            return Err(Error::setting(
                "thresholds",
                format!("{} thresholds given for {} segment levels", s.thresholds.len(), s.segments.len()),
            ));
        }
        for t in &s.thresholds {
            unit("thresholds", *t)?;
        }
        if s.superpixels > 1_000_000 {
            return Err(Error::setting("superpixels", "at most 1000000 (0 = automatic)"));
        }
        nonneg("weight_colour", s.weight_colour)?;
        nonneg("weight_normal", s.weight_normal)?;
        nonneg("weight_depth", s.weight_depth)?;
        unit("weight_object", s.weight_object)?;
        nonneg("weight_saliency", s.weight_saliency)?;
        if s.colors == 1 {
            return Err(Error::setting("colors", "quantising to 1 colour leaves no image; use 0 (off) or >= 2"));
        }
        if s.colors > 4096 {
            return Err(Error::setting("colors", "at most 4096"));
        }
        if let Some(dir) = &s.saliency_cache
            && dir.exists()
            && !dir.is_dir()
        {
            return Err(Error::setting("saliency_cache", format!("{} is not a directory", dir.display())));
        }
        if s.faceting == Faceting::Constant && s.facet_map.is_none() && s.facets.is_none() {
            return Err(Error::setting("facet_map", "constant faceting needs a facet map image (--facet-map)"));
        }
        Ok(())
    }
}
