//! The validated settings: the one contract between the CLI, the JSON config and the add-on.
//!
//! A setting is declared once, in the table of `table` (field and doc, value before any
//! preset, schema entry, range, flag and help), and reaches all three: `Settings`, the flags
//! (`cli/settings_args.rs`, which serialise into the same keys) and the schema the add-on
//! builds its panel from (`cubist settings --schema`). Adding one touches that table and the
//! stage parameter that reads it (`pipeline::params`), nothing else. Layers apply in order:
//! preset defaults, then the JSON file, then explicit flags (`layers`).
//!
//! This module depends on nothing of the crate but `error`: the stages never see `Settings`;
//! `pipeline::params` turns the validated settings into each stage's own parameters.
//!
//! - `table`: every key, declared once; `Settings` and `Settings::base` come from it;
//! - `enums`: the values of the enumerated settings (their JSON and flag names);
//! - `presets`: what each preset sets;
//! - `layers`: preset, then JSON file, then flags;
//! - `validate`: the declared ranges' checks and those of several keys, with the key at fault;
//! - `schema`: the shape of each key's type, unit and range, for `cubist settings --schema`;
//! - `range`: an interval a number may take, as messages and the schema write it;
//! - `frames`: the frame range of `frames`.

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
        // A name: no number to check against a range.
        impl crate::settings::validate::Numbers for $name {}
    };
}

// Declared after the macro, which they use.
mod enums;
mod frames;
mod layers;
mod presets;
mod range;
pub mod schema;
mod table;
mod validate;

pub use table::Settings;
pub(crate) use table::settings_table;

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

impl Settings {
    /// Pixel-valued parameters are given at 1000 px; this converts them to this image's
    /// pixels, scaling with the image's geometric mean side sqrt(w h).
    pub fn pixel_scale(&self) -> f64 {
        ((self.width as f64) * (self.height as f64)).sqrt() / 1000.0
    }
}
