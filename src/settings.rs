//! The validated settings: the one contract between the CLI, the JSON config and the add-on.
//!
//! A parameter is added here once (field, default, doc, validation, schema entry) and reaches
//! all three: the CLI's flags serialise into the same keys (`cli/settings_args.rs`), the
//! add-on's panel is generated from `cubist settings --schema` and writes this JSON. Layers
//! apply in order: preset defaults, then the JSON file, then explicit flags (`layers`).
//!
//! This module depends on nothing of the crate but `error`: the stages never see `Settings`;
//! `pipeline::params` turns the validated settings into each stage's own parameters.
//!
//! - `enums`: the values of the enumerated settings (their JSON and flag names);
//! - `presets`: the values before any preset and what each preset sets;
//! - `layers`: preset, then JSON file, then flags;
//! - `validate`: every value's range, with the key at fault;
//! - `schema`: each key's type, unit and range, for `cubist settings --schema`.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// An enum of settings values with kebab-case names, shared by serde (JSON keys' values) and
/// clap (flag values), and `as_str` for messages.
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

// Declared after the macro, which they use.
mod enums;
mod layers;
mod presets;
pub mod schema;
mod validate;

pub use enums::{
    BorderStyle, CameraKind, FacetMotion, FacetProjection, Faceting, Framing, Imprecision, Palette, Pass,
    SaliencyMethod,
};
pub use validate::{
    MAX_EXPOSURE, MAX_FACETS, MAX_GRID_CELLS, MAX_JOB_MEMORY, MAX_OCCLUSION, MAX_PIXEL_DISTANCE, MAX_PIXELS,
    MAX_PLANES, MAX_SAMPLES, MAX_SCENE_VALUE, MAX_SEGMENT_LEVELS, MAX_SEGMENTS, MAX_SIDE, MAX_SUPERPIXELS, MAX_WEIGHT,
};

kebab_enum!(
    /// Bundles of settings; explicit flags and JSON keys override them.
    Preset {
        /// Our look (the default of `cubist render`): planes over the whole canvas, small at the
        /// subject and large at the edges, the subject composed in proportion, the backdrop kept
        /// still; discontinuity 110, firm broken borders, the ochre-grey palette, brushwork.
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
        /// The thesis's method exactly as the paper has it, for comparisons and evaluations:
        /// Segment faceting (levels 5, 30, 120), every facet re-aimed, eq 4.8 borders, the
        /// recommended 140 deg and discontinuity 200, the `fit` framing; no planes, no
        /// composition, no backdrop rule (what `analytic` was before planes and composition).
        Thesis = "thesis",
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
    /// Samples per pixel of the final image (stratified, seeded); the pre-render that facets
    /// and saliency read traces one, at each pixel's centre.
    pub spp: u32,
    /// Seed of every random choice (sampling, facets, gradients).
    pub seed: u64,

    // ---- sampling
    /// Adaptive anti-aliasing: only pixels that differ from a neighbour of their facet by
    /// more than this (sRGB, 0..1, any channel), or show another object, get `spp` samples;
    /// the others keep their centre sample. 0: every pixel gets `spp`.
    pub aa_threshold: f32,

    // ---- camera
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

    // ---- facets
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

    // ---- planes faceting and what facets show (`facets::planes`, `imprecision::backdrop`)
    /// Planes: how many planes the canvas is split into before the subject's outlines cut them.
    pub planes: u32,
    /// Planes: how much denser the planes are at the most salient parts than far from the
    /// subject (a ratio of planes per area, >= 1).
    pub plane_detail: f64,
    /// Planes: cut the planes along the subject's outlines (silhouettes and object boundaries).
    pub plane_outlines: bool,
    /// A facet is re-aimed only when at least this share of its pixels showed geometry in the
    /// pre-render, in [0, 1]; 0 = every facet (the thesis). Background facets then keep the
    /// backdrop instead of a magnified copy of the subject (a ghost).
    pub aim_min_coverage: f64,
    /// A re-aimed facet's view shifts by at most this share of its mean width (converging
    /// facets), >= 0; 0 = no limit but `discontinuity` (the thesis). Keeps thin parts (an arm,
    /// a finger) in their planes.
    pub aim_width_share: f64,

    // ---- spatial imprecision
    pub imprecision: Imprecision,
    /// Largest distance from facet centre to saliency centre, pixels at 1000 px.
    pub discontinuity: f64,
    /// Pixels outside a facet that still count for its saliency centre, pixels at 1000 px.
    pub neighborhood: f64,
    pub facet_projection: FacetProjection,
    /// Field of view of linear facets, degrees (eq 4.7); 0 = orthographic facets.
    pub facet_fov: f64,

    // ---- painterly effects
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
    /// Per-facet relighting, each facet's lights turned towards its plane's lit side, in
    /// [0, 1]; 0 = off.
    pub chiaroscuro: f64,

    // ---- per-plane light, passage and brushwork (`paint::plane_light`,
    // `paint::passage`, `paint::brushwork`, `paint::canvas`)
    /// Light-to-dark ramp across each facet (each plane lit on its own), in [0, 1]; 0 = off.
    pub plane_light: f64,
    /// How facet borders are drawn: `symmetric` (eq 4.8) or `passage`.
    pub border_style: BorderStyle,
    /// Opacity of the brush-stroke layer, in [0, 1]; 0 = off.
    pub brushwork: f64,
    /// Brush stroke length, pixels at 1000 px.
    pub stroke_length: f64,
    /// Brush stroke width, pixels at 1000 px.
    pub stroke_width: f64,
    /// Canvas weave showing through the paint, in [0, 1]; 0 = off.
    pub canvas_grain: f64,

    // ---- saliency
    pub saliency_method: SaliencyMethod,
    /// Directory keeping per-mesh saliency across runs, keyed by mesh content (animation
    /// frames rendered by separate processes compute each mesh once). None: no disk cache.
    pub saliency_cache: Option<PathBuf>,

    // ---- animation (frames of `cubist render --frames`, or one per process from the add-on)
    /// How facets move from frame to frame: `static` keeps the layout frame's facets on the
    /// image, `follow` carries them with the surfaces they show (a saved layout then has its
    /// follow data beside it, `<layout>.follow`).
    pub facet_motion: FacetMotion,

    // ---- outputs
    /// Extra passes written beside the output as `<stem>.<pass>.png`.
    pub passes: Vec<Pass>,

    // ---- inputs (README "Security")
    /// Let the scene's image and buffer URIs name files outside its folder (absolute paths,
    /// `../`). Off: a scene rendered on a farm reads nothing but its own folder.
    pub allow_external_files: bool,
}

impl Settings {
    /// Pixel-valued parameters are given at 1000 px; this converts them to this image's
    /// pixels, scaling with the image's geometric mean side sqrt(w h).
    pub fn pixel_scale(&self) -> f64 {
        ((self.width as f64) * (self.height as f64)).sqrt() / 1000.0
    }
}
