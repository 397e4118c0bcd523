//! `cubist render --frames`: every frame of a sequence in this process, each written
//! (atomically) as it is done.

use super::report::{Files, add_picture, ms, progress_for, write_and_report};
use crate::cli::frames::frame_path;
use crate::cli::{FramesArgs, RenderArgs};
use crate::error::{Error, Result};
use crate::output::{Outputs, Pass, pass_path};
use crate::pipeline::{self, FramesParams, Prepared, Stage, Timings};
use crate::scene::animation::Choice;
use crate::settings::Settings;

/// The sequence's parameters from the frame range and the animation flags.
fn params(f: &FramesArgs, (first, last): (u32, u32)) -> Result<FramesParams> {
    Ok(FramesParams {
        first,
        last,
        fps: f.fps,
        frame_at_zero: f.frame_at_zero,
        animation: f.animation.as_deref().map(Choice::parse),
        orbit_deg: f.orbit,
        layout_frame: f.layout_frame,
        measure: false,
        rekey: f.rekey.unwrap_or_else(|| FramesParams::turntable_rekey(f.orbit)),
    })
}

/// Renders frames A-B and writes each as `-o`'s pattern names it (`cli::frames::frame_path`).
pub(super) fn frames(args: &RenderArgs, settings: &Settings, range: (u32, u32)) -> Result<()> {
    let mut params = params(&args.frames, range)?;
    let (first, last) = (params.first, params.last);
    // Every flag checked before anything is created, loaded or traced.
    params.validate()?;
    crate::output::check_png_path(&frame_path(&args.output, first))?;
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| {
            Error::System(format!("cannot create the directory {}: {}", dir.display(), super::system(&e)))
        })?;
    }
    let progress = progress_for(args.run.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.run.scene.as_deref(), pipeline::params::load_options(settings))?;
    // By default the first animation and those of other nodes (`Choice::Default`), when the
    // file has any.
    if params.animation.is_none() && prep.scene.rig.as_ref().is_some_and(|r| !r.clips.is_empty()) {
        params.animation = Some(Choice::Default);
    }
    let mut per_frame: Vec<(u32, Timings, Option<f64>)> = Vec::new();
    let summary = pipeline::render_frames(&prep, settings, &params, &progress, &mut |out| {
        let path = frame_path(&args.output, out.frame);
        // A frame's picture and passes all or nothing.
        let mut outputs = Outputs::new();
        add_picture(&mut outputs, &path, &out.image, &out.passes, &out.passes16)?;
        if let Some(motion) = &out.motion {
            outputs.png_rgba16(&pass_path(&path, Pass::Motion.as_str()), motion)?;
        }
        outputs.commit()?;
        per_frame.push((out.frame, out.timings, out.revealed));
        Ok(())
    })?;
    write_and_report(Files::Written, Some(&progress), &summary.warnings, args.run.verbose, || {
        let mut lines = vec![
            format!(
                "scene: {} ({} triangles, {} objects), frames {first}-{last}",
                prep.scene.source.display(),
                prep.world.triangle_count(),
                prep.world.objects.len()
            ),
            format!("camera: {}", summary.camera),
            format!(
                "animation: {}",
                if summary.animations.is_empty() { "none".to_string() } else { summary.animations.join(", ") }
            ),
            format!("kernels: {}", crate::util::cpu::describe()),
            format!("{:>18}: {:>9.1} ms", "load+bvh", ms(prep.build_time)),
        ];
        for (step, t) in &summary.setup.0 {
            lines.push(format!("{step:>18}: {:>9.1} ms (once)", ms(*t)));
        }
        for (frame, timings, revealed) in &per_frame {
            let total = ms(timings.sequential_total());
            let steps: Vec<String> = timings.0.iter().map(|(s, t)| format!("{s} {:.0}", ms(*t))).collect();
            let revealed = revealed.map(|r| format!(", revealed {:.1}%", r * 100.0)).unwrap_or_default();
            lines.push(format!("frame {frame}: {total:.1} ms ({}){revealed}", steps.join(", ")));
        }
        lines
    })
}
