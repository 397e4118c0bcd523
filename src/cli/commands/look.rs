//! `cubist look`: the look report. Renders each scene (files, the still life, the odd scenes),
//! measures it (`pipeline::look`), prints a markdown table or JSON and writes a contact sheet.

use std::path::{Path, PathBuf};

use super::report::say;
use super::{emit, json, system};
use crate::cli::LookArgs;
use crate::error::Result;
use crate::look::{contact_sheet, markdown, odd, scene_files, scene_name};
use crate::pipeline::{self, Prepared};
use crate::progress::Progress;
use crate::scene::Scene;
use crate::settings::Settings;

/// Whether the contact sheet is a JPEG (by its extension); anything else must be a PNG.
fn is_jpeg(sheet: &Path) -> bool {
    sheet.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("jpg"))
}

/// Renders, measures and reports every scene asked for, before and after when `--before`.
pub fn look(mut args: LookArgs) -> Result<()> {
    // The look's targets are stated at 640 x 480.
    let flags = &mut args.settings.flags;
    flags.width = flags.width.or(Some(640));
    flags.height = flags.height.or(Some(480));
    let after = args.settings.resolve()?;
    let before = args.before.map(|p| {
        let mut s = Settings::preset(p);
        (s.width, s.height, s.spp, s.seed) = (after.width, after.height, after.spp, after.seed);
        s
    });
    if let Some(sheet) = &args.sheet
        && !is_jpeg(sheet)
    {
        crate::output::check_png_path(sheet)?;
    }
    // (name, a file, or a scene built in code; None and None: the still life).
    let mut scenes: Vec<(String, Option<PathBuf>, Option<Scene>)> = scene_files(&args.scenes)
        .map_err(|e| system(&e))?
        .into_iter()
        .map(|p| (scene_name(Some(&p)), Some(p), None))
        .collect();
    if args.still_life || (scenes.is_empty() && !args.odd) {
        scenes.push((scene_name(None), None, None));
    }
    if args.odd {
        scenes.extend(odd::odd_scenes().into_iter().map(|(n, s)| (n, None, Some(s))));
    }
    let (mut rows_before, mut rows_after, mut pictures) = (Vec::new(), Vec::new(), Vec::new());
    let mut skipped = Vec::new();
    for (name, path, built) in scenes {
        let loaded = match built {
            Some(s) => Ok(Prepared::new(s)),
            None => Prepared::load(path.as_deref()),
        };
        let prep = match loaded {
            Ok(p) => p,
            Err(e) => {
                skipped.push(format!("{name}: {e}"));
                continue;
            }
        };
        let mut pics = Vec::new();
        for (settings, rows) in [(before.as_ref(), &mut rows_before), (Some(&after), &mut rows_after)] {
            let Some(settings) = settings else { continue };
            let mut look = pipeline::look(&prep, settings, &name)?;
            if let Some(size) = args.time_size {
                look.row.time_big_ms = Some(median_render_ms(&prep, settings, size, args.time_runs)?);
            }
            say(&format!("{name}: fill {:.0}%, straight {:.1}%", 100.0 * look.row.fill, 100.0 * look.row.straight));
            rows.push(look.row);
            pics.push(look.image);
        }
        pictures.push(pics);
    }
    if let Some(sheet) = &args.sheet {
        let rows: Vec<Vec<&image::RgbaImage>> = pictures.iter().map(|p| p.iter().collect()).collect();
        let columns = if before.is_some() { 2 } else { 4 };
        write_sheet(sheet, contact_sheet(&rows, 240, columns))?;
    }
    if args.json {
        let report = serde_json::json!({ "width": after.width, "height": after.height, "before": rows_before, "after": rows_after, "skipped": skipped });
        return emit(&json(&report, true)?);
    }
    let mut text = String::new();
    if let Some(p) = args.before {
        text += &format!("Before (`--preset {p}`):\n\n{}\nAfter:\n\n", markdown(&rows_before));
    }
    text += &markdown(&rows_after);
    for s in &skipped {
        text += &format!("\nskipped: {s}");
    }
    emit(&text)
}

/// The median time of `runs` renders (at least one) at `size` x `size` pixels, milliseconds.
fn median_render_ms(prep: &Prepared, settings: &Settings, size: u32, runs: u32) -> Result<f64> {
    let mut s = settings.clone();
    (s.width, s.height) = (size, size);
    let mut times: Vec<f64> = Vec::new();
    for _ in 0..runs.max(1) {
        let t = std::time::Instant::now();
        pipeline::render(prep, &s, &Progress::silent())?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

/// Writes the contact sheet: a PNG (atomically), or a JPEG, which keeps the committed report
/// small (the PNG of 80 thumbnails is ~5 MB).
fn write_sheet(sheet: &Path, img: image::RgbaImage) -> Result<()> {
    if !is_jpeg(sheet) {
        return crate::output::write_png(sheet, &img);
    }
    let rgb = image::DynamicImage::ImageRgba8(img).to_rgb8();
    let out = std::io::BufWriter::new(std::fs::File::create(sheet).map_err(|e| system(&e))?);
    image::codecs::jpeg::JpegEncoder::new_with_quality(out, 85).encode_image(&rgb).map_err(|e| system(&e))
}
