//! The validated settings: the one contract between the CLI, the JSON config and the add-on.
//!
//! A parameter is added here once (field, default, doc, validation) and reaches all three:
//! the CLI's flags serialise into the same keys (see `cli.rs`), the add-on writes this JSON.
//! Layers apply in order: preset defaults, then the JSON file, then explicit flags.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use crate::error::{Error, Result};

/// Largest image side we accept, pixels.
pub const MAX_SIDE: u32 = 16384;
/// Largest image we accept, pixels (8K x 8K). Together with `MAX_SAMPLES` this bounds memory.
pub const MAX_PIXELS: u64 = 64 * 1024 * 1024;
/// Largest number of primary samples per image (pixels x spp). Each keeps a 12-byte hit
/// record for saliency and face counting: 256 M samples is about 3 GB.
pub const MAX_SAMPLES: u64 = 256 * 1024 * 1024;

macro_rules! kebab_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $variant:ident = $s:literal),+ $(,)? }) => {
        $(#[$m])*
        #[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
        #[serde(rename_all = "kebab-case")]
        pub enum $name { $($(#[$vm])* #[value(name = $s)] #[serde(rename = $s)] $variant),+ }
        impl $name {
            pub fn as_str(self) -> &'static str { match self { $($name::$variant => $s),+ } }
        }
        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result { f.write_str(self.as_str()) }
        }
    };
}

kebab_enum!(
    /// The camera model (SPEC "Cameras").
    CameraKind {
        /// Spherical for compact scenes, cylindrical for tall ones (height >= 1.6 x width).
        Auto = "auto",
        /// Rays start on a sphere and converge on the focal centre (eq 4.2).
        Spherical = "spherical",
        /// Rays converge on a vertical focal line; rows map linearly to height.
        Cylindrical = "cylindrical",
        /// Rays start on a plane and converge on a focal point (eq 4.1).
        Planar = "planar",
        /// Pinhole camera; `ambiguity` is its vertical field of view.
        Perspective = "perspective",
        /// Parallel rays.
        Orthographic = "orthographic",
    }
);

kebab_enum!(
    /// Where a cubist camera's focal centre goes when no focus distance is given.
    Framing {
        /// Behind the scene's centre, so the whole scene fits the convergence angle.
        Fit = "fit",
        /// At the centre of the scene's bounding box (the thesis's literal default).
        Centre = "centre",
    }
);

kebab_enum!(
    /// How the image is split into facets (SPEC "Faceting").
    Faceting {
        /// One facet: the unfaceted cubist view.
        None = "none",
        /// A user's facet map image, each distinct colour a facet.
        Constant = "constant",
        /// Nearest of k stratified random points.
        Voronoi = "voronoi",
        /// Random quadrilaterals painted until every pixel is covered.
        Patch = "patch",
        /// Multiscale normalized-cut segments of the pre-render, selected by saliency.
        Segment = "segment",
    }
);

kebab_enum!(
    /// How each facet's view is re-aimed (SPEC "Spatial imprecision").
    Imprecision {
        /// Towards the facet's saliency centre (eq 4.5).
        Saliency = "saliency",
        /// Towards a random point within the discontinuity radius (User Study I baseline).
        Random = "random",
        /// Not re-aimed.
        None = "none",
    }
);

kebab_enum!(
    /// The rays of a re-aimed facet.
    FacetProjection {
        /// Keep converging on the facet's new focal point (discontinuity 0 = unfaceted).
        Converging = "converging",
        /// Size-keeping linear facets of eq 4.6 (orthographic at facet_fov 0).
        Linear = "linear",
    }
);

kebab_enum!(
    /// Built-in palettes: luminance-ordered colour ramps written for this project (`paint::palette`).
    Palette {
        None = "none",
        /// Picasso and Braque, 1910: umber, ochre, lead white.
        Ochre = "ochre",
        /// Grisaille, 1911: warm blacks, brownish and cool greys.
        Grey = "grey",
        /// Picasso's blue period: Prussian blue to pale blue-grey.
        BluePeriod = "blue-period",
        /// Braque, 1908-09: olive and earth greens to pale ochre.
        Olive = "olive",
    }
);

kebab_enum!(
    /// How mesh saliency's Gaussian means are evaluated (SPEC "Mesh saliency").
    SaliencyMethod {
        /// Exact while the exact sums' work, counted on the mesh, stays under 5e7 pairs (~0.5 s), clustered above.
        Auto = "auto",
        /// The definition's exact sums, whatever the mesh's size.
        Exact = "exact",
        /// Each block of vertices exact or by clusters (cells of sigma / 4), whichever is cheaper: bounded cost, approximate.
        Clustered = "clustered",
    }
);

kebab_enum!(
    /// Bundles of settings; explicit flags and JSON keys override them.
    Preset {
        /// The paper's recommended look (the default of `cubist render`): 140 deg, Segment
        /// facets, discontinuity 200, bold borders, ochre palette, some gradients.
        Analytic = "analytic",
        /// Braque's earthy 1909-10 canvases: olive palette, 8 colours, heavy borders, many
        /// gradients, light manipulated facet by facet.
        Braque = "braque",
        /// Picasso's blue period: blue palette, softer borders, strong silhouettes, gentler
        /// discontinuity.
        BluePeriod = "blue-period",
        /// Grisaille of 1911: grey palette quantised to 6 tones, relit facets.
        Grisaille = "grisaille",
        /// The bare cubist camera: no facets, no painterly effects.
        Plain = "plain",
    }
);

kebab_enum!(
    /// Extra images written beside the output (`out.<pass>.png`).
    Pass {
        /// The per-pixel saliency map, grey.
        Saliency = "saliency",
        /// Facet ids as colours, with facet centres and saliency centres marked.
        Facets = "facets",
        /// Facet ids as 16-bit grey values (for compositing).
        FacetIds = "facet-ids",
        /// Each segmentation level and the final layout (Segment faceting).
        Segments = "segments",
        /// Object ids as colours.
        Objects = "objects",
        /// Shading normals as colours.
        Normals = "normals",
        /// Hit distance, grey, near = white.
        Depth = "depth",
    }
);

/// Every setting of a render. Defaults are the `analytic` preset's; see `Preset::apply`.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    /// The preset the other values started from.
    pub preset: Preset,

    // ---- image and sampling
    /// Output width, pixels.
    pub width: u32,
    /// Output height, pixels.
    pub height: u32,
    /// Samples per pixel (stratified, seeded).
    pub spp: u32,
    /// Seed of every random choice (sampling, facets, gradients).
    pub seed: u64,

    // ---- camera (SPEC "Cameras")
    pub camera: CameraKind,
    /// Convergence angle of cubist cameras, degrees; the vertical field of view of the
    /// perspective camera. None: 140 for cubist cameras, 60 (or the glTF camera's) for perspective.
    pub ambiguity: Option<f64>,
    pub framing: Framing,
    /// Distance from the camera position to the focal centre along the view direction,
    /// scene units. None: chosen by `framing`.
    pub focus_distance: Option<f64>,
    /// Camera position, scene units. None: the glTF scene's camera, else in front (+Z) of the scene.
    pub camera_position: Option<[f64; 3]>,
    /// Point the camera looks at, scene units. None: the glTF camera's view, else the scene's centre.
    pub camera_target: Option<[f64; 3]>,
    /// Camera up vector. None: the glTF camera's up, else +Y.
    pub camera_up: Option<[f64; 3]>,
    /// Planar camera plane height / orthographic view height / cylindrical band height,
    /// scene units. None: fits the scene.
    pub camera_size: Option<f64>,
    /// Fraction of the view the scene fills when the camera is framed automatically: of the
    /// convergence half-angles for cubist cameras (measured on the image plane, i.e. in
    /// tan(angle), for the planar camera), of the smaller image side for perspective and
    /// orthographic cameras. None: 0.8 for cubist cameras, 0.9 for the others.
    pub fill: Option<f64>,

    // ---- shading
    /// Cast one shadow ray per light per hit.
    pub shadows: bool,
    /// Background colour, linear RGB in [0, 1].
    pub background: [f32; 3],
    /// Background alpha 0 in the output PNG.
    pub transparent: bool,
    /// Multiplier on the lights, after the automatic exposure that makes any light units work.
    pub exposure: f32,

    // ---- facets (SPEC "Faceting")
    pub faceting: Faceting,
    /// Facet map image for `constant` faceting.
    pub facet_map: Option<PathBuf>,
    /// Load this facet layout (.json or .png) instead of computing one.
    pub facets: Option<PathBuf>,
    /// Save the facet layout used (.json or .png), for reuse across frames.
    pub save_facets: Option<PathBuf>,
    /// Voronoi: number of facets k.
    pub facet_count: u32,
    /// Voronoi: number of grid cells m the k points are stratified over.
    pub grid_cells: u32,
    /// Patch: number of quadrilaterals n_p of eq 4.3 (more are added until all is covered).
    pub patch_count: u32,
    /// Patch: occlusion ratio r_occ of eq 4.3.
    pub occlusion: f64,
    /// Segment: segments per level.
    pub segments: Vec<u32>,
    /// Segment: mean-saliency threshold per level, in [0, 1].
    pub thresholds: Vec<f64>,
    /// Segment: superpixels the normalized cut groups; 0 = automatic (see `facets::segment`).
    pub superpixels: u32,
    /// Segment: weight of colour (CIELAB) differences in the segmentation's affinity.
    pub weight_colour: f64,
    /// Segment: weight of surface normal differences.
    pub weight_normal: f64,
    /// Segment: weight of relative depth differences.
    pub weight_depth: f64,
    /// Segment: how far object boundaries cut the affinity, in [0, 1]; 1 = segments never
    /// cross an object boundary (a level may then get more than N segments).
    pub weight_object: f64,
    /// Segment: weight of saliency differences.
    pub weight_saliency: f64,

    // ---- spatial imprecision (SPEC "Spatial imprecision")
    pub imprecision: Imprecision,
    /// Largest distance from facet centre to saliency centre, pixels at 1000 px.
    pub discontinuity: f64,
    /// Pixels outside a facet that still count for its saliency centre, pixels at 1000 px.
    pub neighborhood: f64,
    pub facet_projection: FacetProjection,
    /// Field of view of linear facets, degrees (eq 4.7); 0 = orthographic facets.
    pub facet_fov: f64,

    // ---- painterly effects (SPEC "Painterly effects")
    /// Facet border darkening distance md of eq 4.8, pixels at 1000 px; 0 = off.
    pub border_width: f64,
    /// 0 = no darkening, 1 = eq 4.8 as printed.
    pub border_strength: f64,
    /// Silhouette darkening distance, pixels at 1000 px; 0 = off.
    pub silhouette_width: f64,
    pub silhouette_strength: f64,
    /// Built-in palette mapped onto the output's luminance.
    pub palette: Palette,
    /// A painting whose colours are mapped onto the output's luminance (overrides `palette`).
    pub palette_image: Option<PathBuf>,
    /// Quantise to this many colours; 0 = off.
    pub colors: u32,
    /// Fraction of facets that get a gradient overlay on a corner, in [0, 1].
    pub gradients: f64,
    /// Per-facet variation of light direction and intensity, in [0, 1]; 0 = off.
    pub chiaroscuro: f64,

    // ---- saliency (SPEC "Mesh saliency")
    pub saliency_method: SaliencyMethod,
    /// Directory keeping per-mesh saliency across runs, keyed by mesh content (animation
    /// frames rendered by separate processes compute each mesh once). None: no disk cache.
    pub saliency_cache: Option<PathBuf>,

    // ---- outputs
    /// Extra passes written beside the output as `<stem>.<pass>.png`.
    pub passes: Vec<Pass>,
}

impl Default for Settings {
    fn default() -> Self {
        let mut s = Settings::base();
        Preset::Analytic.apply(&mut s);
        s
    }
}

impl Settings {
    /// Values before any preset: the bare cubist camera.
    fn base() -> Self {
        Settings {
            preset: Preset::Plain,
            width: 800,
            height: 600,
            spp: 4,
            seed: 0,
            camera: CameraKind::Auto,
            ambiguity: None,
            framing: Framing::Fit,
            focus_distance: None,
            camera_position: None,
            camera_target: None,
            camera_up: None,
            camera_size: None,
            fill: None,
            shadows: true,
            background: [0.62, 0.56, 0.46],
            transparent: false,
            exposure: 1.0,
            faceting: Faceting::None,
            facet_map: None,
            facets: None,
            save_facets: None,
            facet_count: 150,
            grid_cells: 15,
            patch_count: 80,
            occlusion: 3.0,
            segments: vec![5, 30, 120],
            thresholds: vec![0.0, 0.05, 0.08],
            superpixels: 0,
            weight_colour: 1.0,
            weight_normal: 1.0,
            weight_depth: 0.5,
            weight_object: 0.9,
            weight_saliency: 0.5,
            imprecision: Imprecision::Saliency,
            discontinuity: 0.0,
            neighborhood: 0.0,
            facet_projection: FacetProjection::Converging,
            facet_fov: 0.0,
            border_width: 0.0,
            border_strength: 1.0,
            silhouette_width: 0.0,
            silhouette_strength: 1.0,
            palette: Palette::None,
            palette_image: None,
            colors: 0,
            gradients: 0.0,
            chiaroscuro: 0.0,
            saliency_method: SaliencyMethod::Auto,
            saliency_cache: None,
            passes: Vec::new(),
        }
    }

    /// The settings of a preset, before any override.
    pub fn preset(preset: Preset) -> Self {
        let mut s = Settings::base();
        preset.apply(&mut s);
        s
    }

    /// Builds settings from layers: the preset named by the outermost layer that names one
    /// (flags, then JSON, else `analytic`), then the JSON object, then the flags' object.
    /// Unknown keys are an error naming the key. The result is validated.
    pub fn from_layers(json: Option<(&Path, Value)>, flags: Map<String, Value>) -> Result<Self> {
        let json_obj = match json {
            None => None,
            Some((path, Value::Object(map))) => Some((path, map)),
            Some((path, _)) => {
                return Err(Error::Config {
                    path: path.to_path_buf(),
                    message: "the top level must be a JSON object of settings".into(),
                });
            }
        };
        let preset_of = |map: &Map<String, Value>| -> Result<Option<Preset>> {
            match map.get("preset") {
                None => Ok(None),
                Some(v) => {
                    serde_json::from_value(v.clone()).map(Some).map_err(|e| Error::setting("preset", e.to_string()))
                }
            }
        };
        let preset = match preset_of(&flags)? {
            Some(p) => p,
            None => match &json_obj {
                Some((_, map)) => preset_of(map)?.unwrap_or(Preset::Analytic),
                None => Preset::Analytic,
            },
        };
        let mut merged = match serde_json::to_value(Settings::preset(preset)) {
            Ok(Value::Object(m)) => m,
            _ => unreachable!("Settings serialises to an object"),
        };
        let known: Vec<String> = merged.keys().cloned().collect();
        if let Some((path, map)) = json_obj {
            for (k, v) in map {
                if !known.contains(&k) {
                    return Err(Error::Config {
                        path: path.to_path_buf(),
                        message: format!("unknown key `{k}` (see `cubist render --help` for every setting)"),
                    });
                }
                merged.insert(k, v);
            }
            // Deserialise once here so a bad value is blamed on the file, not the flags.
            let _: Settings = serde_json::from_value(Value::Object(merged.clone()))
                .map_err(|e| Error::Config { path: path.to_path_buf(), message: e.to_string() })?;
        }
        for (k, v) in flags {
            merged.insert(k, v);
        }
        let settings: Settings =
            serde_json::from_value(Value::Object(merged)).map_err(|e| Error::setting("flags", e.to_string()))?;
        settings.validate()?;
        Ok(settings)
    }

    /// Reads a JSON settings file into the layer `from_layers` takes.
    pub fn read_json(path: &Path) -> Result<Value> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::Config { path: path.to_path_buf(), message: e.to_string() })?;
        serde_json::from_str(&text)
            .map_err(|e| Error::Config { path: path.to_path_buf(), message: format!("not valid JSON: {e}") })
    }

    /// Pixel-valued parameters are given at 1000 px; this converts them to this image's
    /// pixels, scaling with the image's geometric mean side sqrt(w h) (SPEC "Parameters").
    pub fn pixel_scale(&self) -> f64 {
        ((self.width as f64) * (self.height as f64)).sqrt() / 1000.0
    }

    /// The convergence angle (or field of view) in degrees actually used by `kind`.
    pub fn angle_deg(&self, kind: CameraKind, gltf_yfov_deg: Option<f64>) -> f64 {
        match (self.ambiguity, kind) {
            (Some(a), _) => a,
            (None, CameraKind::Perspective) => gltf_yfov_deg.unwrap_or(60.0),
            (None, _) => 140.0,
        }
    }

    /// Whether any stage needs the scene's mesh saliency.
    pub fn needs_saliency(&self) -> bool {
        let imprecision_uses = self.imprecision == Imprecision::Saliency && self.faceted() && self.discontinuity > 0.0;
        // A loaded layout replaces the segmentation; the facets pass shows saliency centres.
        let segment_uses = self.faceting == Faceting::Segment && self.facets.is_none();
        imprecision_uses || segment_uses || self.passes.contains(&Pass::Saliency) || self.passes.contains(&Pass::Facets)
    }

    /// Whether the image is split into facets: a faceting method, or a layout loaded with `facets`.
    pub fn faceted(&self) -> bool {
        self.faceting != Faceting::None || self.facets.is_some()
    }

    /// Checks every value's range; the error names the key.
    pub fn validate(&self) -> Result<()> {
        let s = self;
        if s.width == 0 || s.height == 0 {
            return Err(Error::setting("width", format!("image size {}x{} is empty", s.width, s.height)));
        }
        if s.width > MAX_SIDE || s.height > MAX_SIDE {
            return Err(Error::setting(
                "width",
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
        if s.facet_count == 0 || s.facet_count > crate::facets::MAX_FACETS {
            return Err(Error::setting("facet_count", format!("must be in 1..={}", crate::facets::MAX_FACETS)));
        }
        if s.grid_cells == 0 {
            return Err(Error::setting("grid_cells", "must be at least 1"));
        }
        if s.patch_count == 0 || s.patch_count > crate::facets::MAX_FACETS {
            return Err(Error::setting("patch_count", format!("must be in 1..={}", crate::facets::MAX_FACETS)));
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

impl Preset {
    /// Sets the values this preset bundles.
    pub fn apply(self, s: &mut Settings) {
        s.preset = self;
        match self {
            Preset::Plain => {}
            Preset::Analytic => {
                // The thesis's recommendations (Chapter 5): ambiguity 120-150, discontinuity
                // 50-200 at 1000 px, Segment faceting, bold facet borders, a painter's palette.
                s.camera = CameraKind::Auto;
                s.ambiguity = None; // 140 for cubist cameras
                s.faceting = Faceting::Segment;
                s.discontinuity = 200.0;
                s.border_width = 12.0;
                s.border_strength = 0.85;
                s.silhouette_width = 40.0;
                s.silhouette_strength = 0.5;
                s.palette = Palette::Ochre;
                s.gradients = 0.3;
                s.colors = 0;
                s.chiaroscuro = 0.0;
            }
            Preset::Braque => {
                s.camera = CameraKind::Auto;
                s.ambiguity = Some(150.0);
                s.faceting = Faceting::Segment;
                s.discontinuity = 150.0;
                s.border_width = 16.0;
                s.border_strength = 1.0;
                s.silhouette_width = 20.0;
                s.silhouette_strength = 0.5;
                s.palette = Palette::Olive;
                s.gradients = 0.5;
                s.colors = 8;
                s.chiaroscuro = 0.5;
            }
            Preset::BluePeriod => {
                s.camera = CameraKind::Auto;
                s.ambiguity = Some(120.0);
                s.faceting = Faceting::Segment;
                s.discontinuity = 100.0;
                s.border_width = 8.0;
                s.border_strength = 0.7;
                s.silhouette_width = 40.0;
                s.silhouette_strength = 0.5;
                s.palette = Palette::BluePeriod;
                s.gradients = 0.2;
                s.colors = 0;
                s.chiaroscuro = 0.25;
            }
            Preset::Grisaille => {
                s.camera = CameraKind::Auto;
                s.ambiguity = None;
                s.faceting = Faceting::Segment;
                s.discontinuity = 200.0;
                s.border_width = 12.0;
                s.border_strength = 0.9;
                s.silhouette_width = 25.0;
                s.silhouette_strength = 0.4;
                s.palette = Palette::Grey;
                s.gradients = 0.35;
                s.colors = 6;
                s.chiaroscuro = 0.3;
            }
        }
    }
}
