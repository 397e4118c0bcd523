//! `cubist faces`: the faces visible through one or more cameras, per scene and view, as a
//! markdown table or JSON (the thesis's Table 4.1 measure).

use clap::ValueEnum;

use super::{emit, json};
use crate::cli::FacesArgs;
use crate::error::{Error, Result};
use crate::pipeline::{self, Prepared, evaluate};
use crate::settings::CameraKind;

/// Parses `KIND[:DEG]`.
fn parse_view(s: &str) -> Result<(CameraKind, Option<f64>)> {
    let (kind, angle) = match s.split_once(':') {
        Some((k, a)) => {
            let angle = a.trim().parse::<f64>().map_err(|e| {
                Error::Argument(format!("view `{s}`: `{a}` is not a number of degrees: {}", super::system(&e)))
            })?;
            (k, Some(angle))
        }
        None => (s, None),
    };
    let kind = CameraKind::from_str(kind.trim(), true).map_err(|_| {
        Error::setting(
            "view",
            format!("`{s}`: unknown camera `{kind}` (spherical, cylindrical, planar, perspective, orthographic)"),
        )
    })?;
    Ok((kind, angle))
}

/// Evaluates every view of every scene and prints one row each.
pub fn faces(args: FacesArgs) -> Result<()> {
    let base = args.settings.resolve()?;
    let mut views = Vec::new();
    for v in &args.views {
        views.push(parse_view(v)?);
    }
    if views.is_empty() {
        if args.angles.is_empty() {
            views.push((base.camera, base.ambiguity));
        } else {
            views.extend(args.angles.iter().map(|a| (base.camera, Some(*a))));
        }
    }
    let mut rows = Vec::new();
    for scene in &args.scenes {
        let prep = Prepared::load_with(Some(scene), pipeline::params::load_options(&base))?;
        for &(kind, angle) in &views {
            let mut s = base.clone();
            s.camera = kind;
            s.ambiguity = angle.or(base.ambiguity);
            s.validate()?;
            let eval = evaluate(&prep, &s)?;
            let faces = eval.faces;
            let mut row = serde_json::json!({
                "scene": scene.display().to_string(),
                "camera": kind.as_str(),
                "angle": eval.camera.angle_deg,
                "visible": faces.visible,
                "total": faces.total,
                "percent": (faces.percent() * 100.0).round() / 100.0,
                "view": eval.camera,
            });
            if args.ids {
                row["ids"] = serde_json::json!(eval.ids);
            }
            rows.push(row);
        }
    }
    if args.json {
        let table = serde_json::json!({ "width": base.width, "height": base.height, "spp": base.spp, "rows": rows });
        return emit(&json(&table, true)?);
    }
    let mut table = String::from("| scene | camera | angle | visible | total | % |\n|---|---|---|---|---|---|");
    for r in &rows {
        let angle = r["angle"].as_f64().map(|a| format!("{a}")).unwrap_or_else(|| "-".into());
        table += &format!(
            "\n| {} | {} | {} | {} | {} | {:.1} |",
            r["scene"].as_str().unwrap_or(""),
            r["camera"].as_str().unwrap_or(""),
            angle,
            r["visible"],
            r["total"],
            r["percent"].as_f64().unwrap_or(0.0)
        );
    }
    emit(&table)
}
