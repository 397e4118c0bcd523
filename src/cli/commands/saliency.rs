//! `cubist saliency`: the saliency map seen through the camera (a grey PNG) and/or every
//! mesh's per-vertex saliency as JSON on stdout.

use super::report::{Files, ms, progress_for, write_and_report};
use super::{emit, json};
use crate::cli::SaliencyArgs;
use crate::error::Result;
use crate::pipeline::{self, Prepared, Stage};

/// Writes the map (`saliency.png` unless `-o` names one, none with only `--json`) and prints
/// the per-vertex JSON when asked.
pub fn saliency(args: SaliencyArgs) -> Result<()> {
    let settings = args.settings.resolve()?;
    let output = match (&args.output, args.json) {
        (Some(o), _) => Some(o.clone()),
        (None, true) => None,
        (None, false) => Some(std::path::PathBuf::from("saliency.png")),
    };
    if let Some(o) = &output {
        crate::output::check_png_path(o)?;
    }
    let verbose = args.run.verbose;
    let progress = progress_for(args.run.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.run.scene.as_deref(), pipeline::params::load_options(&settings))?;
    let mut stages = Vec::new();
    if let Some(o) = &output {
        let r = pipeline::saliency_map(&prep, &settings, &progress)?;
        // The map is written, and its warnings and camera printed, before the JSON is made.
        let files = Files::Quiet(Box::new(|outputs| outputs.png(o, &r.image)));
        write_and_report(files, None, &r.warnings, verbose, || vec![format!("camera: {}", r.camera)])?;
        stages.extend(r.timings.0);
    }
    if args.json {
        let t = std::time::Instant::now();
        let vertex = crate::saliency::vertex_json(&prep.scene, &prep.saliency, &pipeline::params::saliency(&settings))?;
        stages.push(("vertex saliency", t.elapsed()));
        emit(&json(&vertex, false)?)?;
    }
    write_and_report(Files::Written, Some(&progress), &[], verbose, || {
        let mut lines = vec![
            format!(
                "scene: {} ({} triangles, {} meshes)",
                prep.scene.source.display(),
                prep.world.triangle_count(),
                prep.scene.meshes.len()
            ),
            format!("{:>16}: {:>9.1} ms", "load+bvh", ms(prep.build_time)),
        ];
        lines.extend(stages.iter().map(|(stage, t)| format!("{stage:>16}: {:>9.1} ms", ms(*t))));
        lines
    })
}
