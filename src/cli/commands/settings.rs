//! `cubist settings`: the resolved settings as JSON, or (`--schema`) what every setting is,
//! or (`--stages`) the stages a render of these settings runs.

use super::{emit, json};
use crate::cli::SettingsCmdArgs;
use crate::error::Result;
use crate::pipeline::{Plan, StageParams};

/// Prints the JSON asked for on stdout; nothing is rendered.
pub fn settings(args: SettingsCmdArgs) -> Result<()> {
    if args.schema {
        return emit(&json(&crate::cli::schema(), true)?);
    }
    let settings = args.settings.resolve()?;
    if args.stages {
        let plan = Plan::new(&StageParams::new(&settings));
        let names: Vec<&str> = plan.stages().iter().map(|s| s.name()).collect();
        return emit(&json(&names, false)?);
    }
    emit(&json(&settings, true)?)
}
