//! Every setting as an optional flag, and the layer the flags given make.
//!
//! `SettingsArgs` is generated from the settings' table (`settings::table`), which declares
//! each flag with its key: nothing here names a setting. Each flag serialises under the same
//! key as the JSON config, so flags, config file and presets merge in one place
//! (`Settings::from_layers`).

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use serde_json::{Map, Value};

use crate::error::Result;
use crate::settings::{
    BorderStyle, CameraKind, FacetMotion, FacetProjection, Faceting, Framing, Imprecision, Palette, Pass, Preset,
    SaliencyMethod, Settings, settings_table,
};

/// Generates `SettingsArgs` from the settings' table: each key's flag, with its help and clap
/// attributes as the table writes them.
macro_rules! settings_args {
    ($(
        $(#[doc = $doc:literal])*
        $key:ident : $ty:ty = $base:expr,
            schema $schema:expr,
            $(check $check:expr,)?
            flag $help:literal $(#[$attr:meta])* $flag:ty;
    )*) => {
        /// Every setting as an optional flag. Keys (after serde) are those of `Settings`; flags
        /// not given are left out of the layer, so the config file's or the preset's value stands.
        #[serde_with::skip_serializing_none]
        #[derive(Args, Serialize, Debug, Default)]
        pub struct SettingsArgs {
            $(#[doc = $help] $(#[$attr])* pub $key: $flag,)*
        }
    };
}

settings_table!(settings_args);

/// A flag's number: finite, so that NaN or infinity is an error naming the flag (never read
/// as "automatic"; JSON has no NaN).
pub(crate) fn finite_f64(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("not a number ({e})"))?;
    if v.is_finite() { Ok(v) } else { Err("not a finite number".into()) }
}

/// `finite_f64` for the settings kept as f32 (exposure, background): finite as f32 too.
fn finite_f32(s: &str) -> std::result::Result<f32, String> {
    let v = finite_f64(s)?;
    let f = v as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        Err(format!("{} is beyond the range of this setting", crate::error::short_num(v)))
    }
}

impl SettingsArgs {
    /// The flags given, as a JSON object under `Settings`' keys.
    pub fn to_layer(&self) -> Map<String, Value> {
        match serde_json::to_value(self) {
            Ok(Value::Object(m)) => m,
            _ => Map::new(),
        }
    }

    /// Validated settings from the optional config file and these flags.
    pub fn resolve(&self, config: Option<&std::path::Path>) -> Result<Settings> {
        let json = match config {
            Some(p) => Some((p, Settings::read_json(p)?)),
            None => None,
        };
        Settings::from_layers(json.as_ref().map(|(p, v)| (*p, v.clone())), self.to_layer())
    }
}
