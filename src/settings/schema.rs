//! What each settings key holds: its type, unit and allowed range, in `Settings` order. With
//! the flags' help (`cli::schema`) this is what `cubist settings --schema` prints, and what
//! the Blender add-on builds its panel from, so no front end copies a range by hand.
//!
//! `validate` is the authority on what is accepted; a test checks every range here against
//! it at both ends, so the two cannot drift apart.

use clap::ValueEnum;
use serde::Serialize;

use super::validate::{
    MAX_EXPOSURE, MAX_GRID_CELLS, MAX_OCCLUSION, MAX_PIXEL_DISTANCE, MAX_SCENE_VALUE, MAX_SEGMENTS, MAX_SUPERPIXELS,
    MAX_WEIGHT,
};
use super::{
    BorderStyle, CameraKind, FacetMotion, FacetProjection, Faceting, Framing, Imprecision, Palette, Pass, Preset,
    SaliencyMethod,
};
use super::{MAX_FACETS, MAX_PLANES, MAX_SIDE};

/// The JSON type of a key's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    Boolean,
    Integer,
    Number,
    /// One of `choices`, by name.
    Enum,
    /// A file or directory path, as a string.
    Path,
    /// A list of `items`; `length` when fixed.
    Array,
}

/// An interval of numbers: [min, max], either end open when its flag says so, `max` None for
/// no upper bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: Option<f64>,
    pub min_exclusive: bool,
    pub max_exclusive: bool,
}

impl Range {
    /// [min, max].
    pub const fn closed(min: f64, max: f64) -> Range {
        Range { min, max: Some(max), min_exclusive: false, max_exclusive: false }
    }
    /// [min, infinity).
    pub const fn at_least(min: f64) -> Range {
        Range { min, max: None, min_exclusive: false, max_exclusive: false }
    }
    /// (min, infinity).
    pub const fn above(min: f64) -> Range {
        Range { min, max: None, min_exclusive: true, max_exclusive: false }
    }
    pub const fn open_min(self) -> Range {
        Range { min_exclusive: true, ..self }
    }
    pub const fn open_max(self) -> Range {
        Range { max_exclusive: true, ..self }
    }
}

/// Pixels of the image.
pub const PX: &str = "px";
/// Pixels at 1000 px, scaled with sqrt(width x height) / 1000.
pub const PX_AT_1000: &str = "px at 1000 px";
pub const DEGREES: &str = "deg";
/// The scene file's units.
pub const SCENE_UNITS: &str = "scene units";
pub const LINEAR_RGB: &str = "linear RGB";

/// One settings key.
#[derive(Clone, Copy, Debug)]
pub struct Field {
    pub key: &'static str,
    pub kind: Kind,
    /// For arrays: the items' kind.
    pub items: Option<Kind>,
    /// For fixed-size arrays: their length.
    pub length: Option<usize>,
    /// Whether `null` is a value (the renderer then chooses per scene; see the help).
    pub nullable: bool,
    pub unit: Option<&'static str>,
    /// Of the value, or of each item of an array.
    pub range: Option<Range>,
    /// For enums and arrays of enums: every value's name and help, in order.
    pub choices: Option<fn() -> Vec<Choice>>,
}

/// One value of an enumerated key.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Choice {
    pub value: String,
    pub help: String,
}

/// The values of a settings enum with their doc comments (clap keeps them as help).
pub fn choices<T: ValueEnum>() -> Vec<Choice> {
    T::value_variants()
        .iter()
        .filter_map(|v| v.to_possible_value())
        .map(|p| Choice {
            value: p.get_name().to_string(),
            help: p.get_help().map(|h| h.to_string()).unwrap_or_default(),
        })
        .collect()
}

const fn field(key: &'static str, kind: Kind) -> Field {
    Field { key, kind, items: None, length: None, nullable: false, unit: None, range: None, choices: None }
}

impl Field {
    const fn unit(self, unit: &'static str) -> Field {
        Field { unit: Some(unit), ..self }
    }
    const fn range(self, range: Range) -> Field {
        Field { range: Some(range), ..self }
    }
    const fn nullable(self) -> Field {
        Field { nullable: true, ..self }
    }
    const fn of(self, items: Kind) -> Field {
        Field { items: Some(items), ..self }
    }
    const fn length(self, n: usize) -> Field {
        Field { length: Some(n), ..self }
    }
    const fn choices(self, choices: fn() -> Vec<Choice>) -> Field {
        Field { choices: Some(choices), ..self }
    }
}

use Kind::{Array, Boolean, Enum, Integer, Number, Path};

const UNIT: Range = Range::closed(0.0, 1.0);
const NON_NEGATIVE: Range = Range::at_least(0.0);
const WEIGHT: Range = Range::closed(0.0, MAX_WEIGHT);
const DISTANCE_PX: Range = Range::closed(0.0, MAX_PIXEL_DISTANCE);
const SCENE_LENGTH: Range = Range::closed(0.0, MAX_SCENE_VALUE).open_min();
const SCENE_POINT: Range = Range::closed(-MAX_SCENE_VALUE, MAX_SCENE_VALUE);
const SIDE: Range = Range::closed(1.0, MAX_SIDE as f64);
const FACETS: Range = Range::closed(1.0, MAX_FACETS as f64);

/// Every key of `Settings`, in its order.
pub const FIELDS: &[Field] = &[
    field("preset", Enum).choices(choices::<Preset>),
    field("width", Integer).unit(PX).range(SIDE),
    field("height", Integer).unit(PX).range(SIDE),
    field("spp", Integer).range(Range::at_least(1.0)),
    field("seed", Integer).range(NON_NEGATIVE),
    field("aa_threshold", Number).range(UNIT),
    field("camera", Enum).choices(choices::<CameraKind>),
    // Planar cameras: [0, 180); perspective: (0, 180).
    field("ambiguity", Number).nullable().unit(DEGREES).range(Range::closed(0.0, 360.0)),
    field("framing", Enum).choices(choices::<Framing>),
    field("focus_distance", Number).nullable().unit(SCENE_UNITS).range(SCENE_LENGTH),
    field("camera_position", Array).of(Number).length(3).nullable().unit(SCENE_UNITS).range(SCENE_POINT),
    field("camera_target", Array).of(Number).length(3).nullable().unit(SCENE_UNITS).range(SCENE_POINT),
    field("camera_up", Array).of(Number).length(3).nullable().range(SCENE_POINT),
    field("camera_size", Number).nullable().unit(SCENE_UNITS).range(SCENE_LENGTH),
    field("fill", Number).nullable().range(UNIT.open_min()),
    field("shadows", Boolean),
    field("background", Array).of(Number).length(3).unit(LINEAR_RGB).range(Range::closed(0.0, MAX_EXPOSURE)),
    field("transparent", Boolean),
    field("exposure", Number).range(Range::closed(0.0, MAX_EXPOSURE)),
    field("faceting", Enum).choices(choices::<Faceting>),
    field("facet_map", Path).nullable(),
    field("facets", Path).nullable(),
    field("save_facets", Path).nullable(),
    field("facet_count", Integer).range(FACETS),
    field("grid_cells", Integer).range(Range::closed(1.0, MAX_GRID_CELLS as f64)),
    field("patch_count", Integer).range(FACETS),
    field("occlusion", Number).range(Range::closed(0.0, MAX_OCCLUSION).open_min()),
    field("segments", Array).of(Integer).range(Range::closed(1.0, MAX_SEGMENTS as f64)),
    field("thresholds", Array).of(Number).range(UNIT),
    field("superpixels", Integer).range(Range::closed(0.0, MAX_SUPERPIXELS as f64)),
    field("weight_colour", Number).range(WEIGHT),
    field("weight_normal", Number).range(WEIGHT),
    field("weight_depth", Number).range(WEIGHT),
    field("weight_object", Number).range(UNIT),
    field("weight_saliency", Number).range(WEIGHT),
    field("planes", Integer).range(Range::closed(1.0, MAX_PLANES as f64)),
    field("plane_detail", Number).range(Range::closed(1.0, 100.0)),
    field("plane_outlines", Boolean),
    field("aim_min_coverage", Number).range(UNIT),
    field("aim_width_share", Number).range(Range::closed(0.0, 100.0)),
    field("imprecision", Enum).choices(choices::<Imprecision>),
    field("discontinuity", Number).unit(PX_AT_1000).range(DISTANCE_PX),
    field("neighborhood", Number).unit(PX_AT_1000).range(DISTANCE_PX),
    field("facet_projection", Enum).choices(choices::<FacetProjection>),
    field("facet_fov", Number).unit(DEGREES).range(Range::closed(0.0, 180.0).open_max()),
    field("border_width", Number).unit(PX_AT_1000).range(DISTANCE_PX),
    field("border_strength", Number).range(UNIT),
    field("silhouette_width", Number).unit(PX_AT_1000).range(DISTANCE_PX),
    field("silhouette_strength", Number).range(UNIT),
    field("palette", Enum).choices(choices::<Palette>),
    field("palette_image", Path).nullable(),
    // 1 is refused: quantising to one colour leaves no image.
    field("colors", Integer).range(Range::closed(0.0, 4096.0)),
    field("gradients", Number).range(UNIT),
    field("chiaroscuro", Number).range(UNIT),
    field("plane_light", Number).range(UNIT),
    field("border_style", Enum).choices(choices::<BorderStyle>),
    field("brushwork", Number).range(UNIT),
    field("stroke_length", Number).unit(PX_AT_1000).range(Range::closed(0.0, 1000.0).open_min()),
    field("stroke_width", Number).unit(PX_AT_1000).range(Range::closed(0.0, 1000.0).open_min()),
    field("canvas_grain", Number).range(UNIT),
    field("saliency_method", Enum).choices(choices::<SaliencyMethod>),
    field("saliency_cache", Path).nullable(),
    field("facet_motion", Enum).choices(choices::<FacetMotion>),
    field("passes", Array).of(Enum).choices(choices::<Pass>),
    field("allow_external_files", Boolean),
];
