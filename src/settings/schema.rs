//! What each settings key holds: its type, unit and allowed range, in `Settings` order. The
//! entries (`FIELDS`) are declared with the keys, in `table`; this module has their shape and
//! the builders the table writes them with. With the flags' help (`cli::schema`) this is what
//! `cubist settings --schema` prints, and what the Blender add-on builds its panel from, so no
//! front end copies a range by hand.
//!
//! A declared range is what validation accepts (`Settings::check_ranges` checks it); a test
//! checks every range at both ends against `Settings::validate`, cross-field checks included.

use clap::ValueEnum;
use serde::Serialize;

pub use super::range::Range;

use super::validate::{MAX_PIXEL_DISTANCE, MAX_SCENE_VALUE, MAX_WEIGHT};
use super::{MAX_FACETS, MAX_SIDE};

pub use super::table::FIELDS;

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
    /// Text in a format the key's help gives (`frames`: `A-B`).
    #[serde(rename = "string")]
    Text,
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

/// A key's entry of `kind`; the table names it (`Field::key`).
pub(super) const fn field(kind: Kind) -> Field {
    Field { key: "", kind, items: None, length: None, nullable: false, unit: None, range: None, choices: None }
}

impl Field {
    pub(super) const fn key(self, key: &'static str) -> Field {
        Field { key, ..self }
    }
    pub(super) const fn unit(self, unit: &'static str) -> Field {
        Field { unit: Some(unit), ..self }
    }
    pub(super) const fn range(self, range: Range) -> Field {
        Field { range: Some(range), ..self }
    }
    pub(super) const fn nullable(self) -> Field {
        Field { nullable: true, ..self }
    }
    pub(super) const fn of(self, items: Kind) -> Field {
        Field { items: Some(items), ..self }
    }
    pub(super) const fn length(self, n: usize) -> Field {
        Field { length: Some(n), ..self }
    }
    pub(super) const fn choices(self, choices: fn() -> Vec<Choice>) -> Field {
        Field { choices: Some(choices), ..self }
    }
}

// Ranges several keys share.
pub(super) const UNIT: Range = Range::closed(0.0, 1.0);
pub(super) const NON_NEGATIVE: Range = Range::at_least(0.0);
pub(super) const WEIGHT: Range = Range::closed(0.0, MAX_WEIGHT);
pub(super) const DISTANCE_PX: Range = Range::closed(0.0, MAX_PIXEL_DISTANCE);
pub(super) const SCENE_LENGTH: Range = Range::closed(0.0, MAX_SCENE_VALUE).open_min();
pub(super) const SCENE_POINT: Range = Range::closed(-MAX_SCENE_VALUE, MAX_SCENE_VALUE);
pub(super) const SIDE: Range = Range::closed(1.0, MAX_SIDE as f64);
pub(super) const FACETS: Range = Range::closed(1.0, MAX_FACETS as f64);
