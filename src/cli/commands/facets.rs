//! `cubist facets`: a scene's Segment facet layout written as images (the pre-render, the
//! layout, and with `--pass segments` the superpixels and each level).

use super::report::{Files, ms, progress_for, write_and_report};
use crate::cli::FacetsArgs;
use crate::error::Result;
use crate::output::pass_path;
use crate::pipeline::{self, Prepared, Stage};

/// Computes the layout and writes its images (and the layout itself with `--save-facets`).
pub fn facets(args: FacetsArgs) -> Result<()> {
    let settings = args.settings.resolve()?;
    crate::output::check_png_path(&args.output)?;
    let progress = progress_for(args.run.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.run.scene.as_deref(), pipeline::params::load_options(&settings))?;
    let out = pipeline::inspect_facets(&prep, &settings, &progress)?;
    // The facet map a saved `.png` layout is written from.
    let saved = settings.save_facets.as_ref().map(|path| (path, out.layout.rasterize(settings.width, settings.height)));
    let files = Files::Staged(Box::new(|outputs| {
        outputs.png(&args.output, &out.view)?;
        for (name, img) in &out.images {
            outputs.png(&pass_path(&args.output, name), img)?;
        }
        if let Some((path, map)) = &saved {
            crate::facets::io::add_to(outputs, path, &out.layout, map)?;
        }
        Ok(())
    }));
    write_and_report(files, Some(&progress), &out.warnings, args.run.verbose, || {
        let mut lines = Vec::new();
        for l in &out.levels.levels {
            let chosen = l.selected.iter().filter(|s| **s).count();
            lines.push(format!(
                "level N={}: {} segments, {} selected (mean saliency >= {})",
                l.requested, l.count, chosen, l.threshold
            ));
        }
        lines.push(format!("superpixels: {}, facets: {}", out.levels.superpixel_count, out.layout.facet_count));
        let steps = out.timings.0.iter().map(|(s, t)| (s.to_string(), *t));
        for (stage, t) in steps.chain(out.levels.timings.iter().cloned()) {
            lines.push(format!("{stage:>14}: {:>9.1} ms", ms(t)));
        }
        lines
    })
}
