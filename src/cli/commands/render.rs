//! `cubist render`: a still, a still whose facets follow a saved key frame, or (`--frames`) a
//! sequence (`frames`).

use super::report::{Files, add_picture, ms, progress_for, say, write_and_report};
use crate::cli::RenderArgs;
use crate::error::Result;
use crate::pipeline::{self, Prepared, Stage};
use crate::settings::Settings;

/// Renders what the flags ask for and writes the picture, its passes and any saved layout.
pub fn render(args: RenderArgs) -> Result<()> {
    let settings = args.settings.resolve()?;
    if let Some(range) = settings.frame_range()? {
        return super::frames::frames(&args, &settings, range);
    }
    pipeline::params::check_still_passes(&settings)?;
    if pipeline::follows_saved_key(&settings) {
        return followed(&args, &settings);
    }
    still(&args, settings)
}

/// One picture of the scene as loaded.
fn still(args: &RenderArgs, mut settings: Settings) -> Result<()> {
    crate::output::check_png_path(&args.output)?;
    let progress = progress_for(args.run.progress);
    progress.begin(Stage::Loading.name(), 1);
    // Mesh saliency beside the BVH build when the render will need it.
    let saliency = pipeline::params::mesh_saliency_ahead(&settings);
    let (prep, mesh_saliency) = Prepared::load_for_render(
        args.run.scene.as_deref(),
        pipeline::params::load_options(&settings),
        saliency.as_ref(),
    )?;
    // The layout is saved with the images, all or nothing, not by the render.
    let save_facets = settings.save_facets.take();
    let rendered = pipeline::render(&prep, &settings, &progress)?;
    if let Some(rig) = &prep.scene.rig {
        say(&format!(
            "warning: {} animation(s) not played: a still shows the scene as loaded (render frames with --frames A-B)",
            rig.clips.len()
        ));
    }
    let files = Files::Staged(Box::new(|outputs| {
        add_picture(outputs, &args.output, &rendered.image, &rendered.passes, &rendered.passes16)?;
        if let Some(path) = &save_facets {
            crate::facets::io::add_to(outputs, path, &rendered.layout, &rendered.facets)?;
        }
        Ok(())
    }));
    write_and_report(files, Some(&progress), &rendered.warnings, args.run.verbose, || {
        let mut lines = vec![
            format!(
                "scene: {} ({} triangles, {} objects)",
                prep.scene.source.display(),
                prep.world.triangle_count(),
                prep.world.objects.len()
            ),
            format!("camera: {}", rendered.camera),
            format!("kernels: {}", crate::util::cpu::describe()),
            format!("{:>14}: {:>9.1} ms", "load+bvh", ms(prep.build_time)),
        ];
        if let Some(t) = mesh_saliency {
            lines.push(format!("{:>14}: {:>9.1} ms, beside the BVH build", "mesh saliency", ms(t)));
        }
        for (i, (stage, t)) in rendered.timings.0.iter().enumerate() {
            if *stage == pipeline::MESH_SALIENCY_OVERLAPPED {
                // Its CPU is counted in framing's and the pre-render's, which it ran beside.
                lines.push(format!("{stage:>14}: {:>9.1} ms, beside framing and pre-render", ms(*t)));
                continue;
            }
            let cpu = rendered.timings.cpu(i).map_or(String::new(), |c| format!(" ({:.1} ms CPU)", ms(c)));
            lines.push(format!("{stage:>14}: {:>9.1} ms{cpu}", ms(*t)));
        }
        lines
    })
}

/// A still with `--facet-motion follow` and a layout file: one frame whose facets are carried
/// from the key frame saved beside the layout (`pipeline::render_followed_frame`), or, with
/// `--save-facets`, the key frame itself (its layout and follow data saved before the picture).
fn followed(args: &RenderArgs, settings: &Settings) -> Result<()> {
    crate::output::check_png_path(&args.output)?;
    let progress = progress_for(args.run.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.run.scene.as_deref(), pipeline::params::load_options(settings))?;
    let (out, summary) = pipeline::render_followed_frame(&prep, settings, &progress)?;
    let files =
        Files::Staged(Box::new(|outputs| add_picture(outputs, &args.output, &out.image, &out.passes, &out.passes16)));
    write_and_report(files, Some(&progress), &summary.warnings, args.run.verbose, || {
        let mut lines = vec![
            format!(
                "scene: {} ({} triangles, {} objects), facets following the key frame",
                prep.scene.source.display(),
                prep.world.triangle_count(),
                prep.world.objects.len()
            ),
            format!("camera: {}", summary.camera),
            format!("{:>18}: {:>9.1} ms", "load+bvh", ms(prep.build_time)),
        ];
        for (step, t) in summary.setup.0.iter().chain(out.timings.0.iter()) {
            lines.push(format!("{step:>18}: {:>9.1} ms", ms(*t)));
        }
        if let Some(r) = out.revealed {
            lines.push(format!("facets carried from the key frame, revealed {:.1}%", r * 100.0));
        }
        lines
    })
}
