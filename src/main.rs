//! The `cubist` binary: parse flags, build validated settings, call the library, map errors
//! to exit codes (1 failure, 2 usage).

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use cubist::cli::{
    Cli, Command, FacesArgs, FacetsArgs, LookArgs, ProgressMode, RenderArgs, SaliencyArgs, ServeArgs, SettingsCmdArgs,
};
use cubist::output::{Gray16, Outputs, Pass, pass_path, write_png};
use cubist::pipeline::{self, Plan, Stage, StageParams, evaluate};
use cubist::progress::Progress;
use cubist::settings::CameraKind;
use cubist::{Error, Prepared};

/// Writes a line to stderr. Never `eprintln!`: it panics (exit 101) when stderr is closed or
/// its reader went away; a message that cannot be written is dropped and the exit code says it.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

fn main() -> ExitCode {
    handle_signals();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            if e.use_stderr() {
                say!("{}", usage_error(&e.render().to_string()));
                return ExitCode::from(2);
            }
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
    };
    let result = match cli.command {
        Command::Render(args) => run_render(args),
        Command::Faces(args) => run_faces(args),
        Command::Saliency(args) => run_saliency(args),
        Command::Facets(args) => run_facets(args),
        Command::Settings(args) => run_settings(args),
        Command::Look(args) => run_look(args),
        Command::Serve(args) => run_serve(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let usage = e.downcast_ref::<Error>().is_some_and(Error::is_usage);
            say!("error: {}", cubist::error::cap_message(&format!("{e:#}")));
            ExitCode::from(if usage { 2 } else { 1 })
        }
    }
}

/// clap's usage error as we print it: the first line names the problem (clap ends some first
/// lines with a colon and lists the arguments below), and no line echoes a huge value whole.
fn usage_error(rendered: &str) -> String {
    let lines: Vec<&str> = rendered.trim_end().lines().collect();
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    if let Some(first) = lines.first() {
        let mut first = first.trim_end().to_string();
        i = 1;
        if first.ends_with(':') {
            // "the following required arguments were not provided:" + the indented list.
            let mut items = Vec::new();
            while i < lines.len() && lines[i].starts_with(' ') && !lines[i].trim().is_empty() {
                items.push(lines[i].trim());
                i += 1;
            }
            first = format!("{first} {}", items.join(", "));
        }
        out.push(first);
    }
    out.extend(lines[i..].iter().map(|l| l.to_string()));
    out.iter().map(|l| cubist::error::cap_message(l)).collect::<Vec<_>>().join("\n")
}

/// SIGINT and SIGTERM (the add-on's cancel, a farm's job kill) and SIGHUP remove the temporary
/// files of outputs being written, then exit with 128 + the signal: nothing partial remains.
#[cfg(unix)]
fn handle_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else { return };
    let _ = std::thread::Builder::new().name("signals".into()).spawn(move || {
        if let Some(sig) = signals.forever().next() {
            cubist::util::files::remove_temporary_files();
            std::process::exit(128 + sig);
        }
    });
}

#[cfg(windows)]
fn handle_signals() {
    let _ = ctrlc::set_handler(|| {
        cubist::util::files::remove_temporary_files();
        std::process::exit(130);
    });
}

#[cfg(not(any(unix, windows)))]
fn handle_signals() {}

fn progress_for(mode: ProgressMode) -> Progress {
    let mode = match mode {
        ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
        ProgressMode::Auto => ProgressMode::None,
        m => m,
    };
    match mode {
        ProgressMode::Bar => {
            let bar = indicatif::ProgressBar::new(1000);
            bar.set_style(
                indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}%")
                    .expect("static template")
                    .progress_chars("=> "),
            );
            Progress::new(Box::new(move |stage, f| {
                bar.set_message(stage.to_string());
                bar.set_position((f * 1000.0) as u64);
                if f >= 1.0 && stage == Stage::Done.name() {
                    bar.finish_and_clear();
                }
            }))
        }
        // Written without `eprintln!`, which panics if the reader (the add-on) went away.
        ProgressMode::Lines => Progress::new(Box::new(|stage, f| say!("PROGRESS {f:.4} {stage}"))),
        _ => Progress::silent(),
    }
}

fn run_render(args: RenderArgs) -> anyhow::Result<()> {
    let mut settings = args.settings.resolve(args.config.as_deref())?;
    if let Some(range) = settings.frame_range()? {
        return run_frames(args, settings, range);
    }
    pipeline::params::check_still_passes(&settings)?;
    if pipeline::follows_saved_key(&settings) {
        return run_followed(args, settings);
    }
    cubist::output::check_png_path(&args.output)?;
    let progress = progress_for(args.progress);
    progress.begin(Stage::Loading.name(), 1);
    // Mesh saliency beside the BVH build when the render will need it.
    let saliency = pipeline::params::mesh_saliency_ahead(&settings);
    let (prep, mesh_saliency) =
        Prepared::load_for_render(args.scene.as_deref(), pipeline::params::load_options(&settings), saliency.as_ref())?;
    // The layout is saved with the images, all or nothing, not by the render.
    let save_facets = settings.save_facets.take();
    let rendered = cubist::render(&prep, &settings, &progress)?;
    if let Some(rig) = &prep.scene.rig {
        say!(
            "warning: {} animation(s) not played: a still shows the scene as loaded (render frames with --frames A-B)",
            rig.clips.len()
        );
    }
    progress.begin(Stage::Writing.name(), 1);
    let mut outputs = Outputs::new();
    add_picture(&mut outputs, &args.output, &rendered.image, &rendered.passes, &rendered.passes16)?;
    if let Some(path) = &save_facets {
        cubist::facets::io::add_to(&mut outputs, path, &rendered.layout, &rendered.facets)?;
    }
    outputs.commit()?;
    progress.begin(Stage::Done.name(), 1);
    progress.finish();
    for w in &rendered.warnings {
        say!("warning: {w}");
    }
    if args.verbose {
        say!(
            "scene: {} ({} triangles, {} objects)",
            prep.scene.source.display(),
            prep.world.triangle_count(),
            prep.world.objects.len()
        );
        say!("camera: {}", rendered.camera);
        say!("kernels: {}", cubist::util::cpu::describe());
        say!("{:>14}: {:>9.1} ms", "load+bvh", prep.build_time.as_secs_f64() * 1e3);
        if let Some(t) = mesh_saliency {
            say!("{:>14}: {:>9.1} ms, beside the BVH build", "mesh saliency", t.as_secs_f64() * 1e3);
        }
        for (i, (stage, t)) in rendered.timings.0.iter().enumerate() {
            let cpu =
                rendered.timings.cpu(i).map_or(String::new(), |c| format!(" ({:.1} ms CPU)", c.as_secs_f64() * 1e3));
            if *stage == pipeline::MESH_SALIENCY_OVERLAPPED {
                // Its CPU is counted in framing's and the pre-render's, which it ran beside.
                say!("{stage:>14}: {:>9.1} ms, beside framing and pre-render", t.as_secs_f64() * 1e3);
                continue;
            }
            say!("{stage:>14}: {:>9.1} ms{cpu}", t.as_secs_f64() * 1e3);
        }
    }
    Ok(())
}

/// Adds a render's picture at `path` and each pass beside it (`pass_path`), for one
/// all-or-nothing commit.
fn add_picture<'a>(
    outputs: &mut Outputs<'a>,
    path: &Path,
    image: &'a image::RgbaImage,
    passes: &'a [(Pass, image::RgbaImage)],
    passes16: &'a [(Pass, Gray16)],
) -> cubist::error::Result<()> {
    outputs.png(path, image)?;
    for (pass, img) in passes {
        outputs.png(&pass_path(path, pass.as_str()), img)?;
    }
    for (pass, img) in passes16 {
        outputs.png16(&pass_path(path, pass.as_str()), img)?;
    }
    Ok(())
}

/// A still with `--facet-motion follow` and a layout file: one frame whose facets are carried
/// from the key frame saved beside the layout (`pipeline::render_followed_frame`), or, with
/// `--save-facets`, the key frame itself (its layout and follow data saved before the picture).
fn run_followed(args: RenderArgs, settings: cubist::Settings) -> anyhow::Result<()> {
    cubist::output::check_png_path(&args.output)?;
    let progress = progress_for(args.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.scene.as_deref(), pipeline::params::load_options(&settings))?;
    let (out, summary) = pipeline::render_followed_frame(&prep, &settings, &progress)?;
    progress.begin(Stage::Writing.name(), 1);
    let mut outputs = Outputs::new();
    add_picture(&mut outputs, &args.output, &out.image, &out.passes, &out.passes16)?;
    outputs.commit()?;
    progress.begin(Stage::Done.name(), 1);
    progress.finish();
    for w in &summary.warnings {
        say!("warning: {w}");
    }
    if args.verbose {
        say!(
            "scene: {} ({} triangles, {} objects), facets following the key frame",
            prep.scene.source.display(),
            prep.world.triangle_count(),
            prep.world.objects.len()
        );
        say!("camera: {}", summary.camera);
        let revealed = out.revealed.map(|r| format!(", revealed {:.1}%", r * 100.0)).unwrap_or_default();
        say!("{:>18}: {:>9.1} ms", "load+bvh", prep.build_time.as_secs_f64() * 1e3);
        for (step, t) in summary.setup.0.iter().chain(out.timings.0.iter()) {
            say!("{step:>18}: {:>9.1} ms", t.as_secs_f64() * 1e3);
        }
        if !revealed.is_empty() {
            say!("facets carried from the key frame{revealed}");
        }
    }
    Ok(())
}

/// `render --frames`: every frame in this process, each written (atomically) as it is done.
fn run_frames(args: RenderArgs, settings: cubist::Settings, (first, last): (u32, u32)) -> anyhow::Result<()> {
    use cubist::cli::frames::frame_path;
    use cubist::pipeline::FramesParams;
    use cubist::scene::animation::Choice;
    let f = &args.frames;
    let mut params = FramesParams {
        first,
        last,
        fps: f.fps,
        animation: f.animation.as_deref().map(Choice::parse),
        orbit_deg: f.orbit,
        layout_frame: f.layout_frame,
        measure: false,
        rekey: f.rekey.unwrap_or_else(|| FramesParams::turntable_rekey(f.orbit)),
    };
    // Every flag checked before anything is created, loaded or traced.
    params.validate()?;
    cubist::output::check_png_path(&frame_path(&args.output, first))?;
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create the directory {}", dir.display()))?;
    }
    let progress = progress_for(args.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.scene.as_deref(), pipeline::params::load_options(&settings))?;
    // The first animation by default, when the file has any.
    if params.animation.is_none() && prep.scene.rig.as_ref().is_some_and(|r| !r.clips.is_empty()) {
        params.animation = Some(Choice::Index(0));
    }
    let mut per_frame: Vec<(u32, cubist::pipeline::Timings, Option<f64>)> = Vec::new();
    let summary = pipeline::render_frames(&prep, &settings, &params, &progress, &mut |out| {
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
    progress.begin(Stage::Done.name(), 1);
    progress.finish();
    for w in &summary.warnings {
        say!("warning: {w}");
    }
    if args.verbose {
        say!(
            "scene: {} ({} triangles, {} objects), frames {first}-{last}",
            prep.scene.source.display(),
            prep.world.triangle_count(),
            prep.world.objects.len()
        );
        say!("camera: {}", summary.camera);
        say!("kernels: {}", cubist::util::cpu::describe());
        say!("{:>18}: {:>9.1} ms", "load+bvh", prep.build_time.as_secs_f64() * 1e3);
        for (step, t) in &summary.setup.0 {
            say!("{step:>18}: {:>9.1} ms (once)", t.as_secs_f64() * 1e3);
        }
        for (frame, timings, revealed) in &per_frame {
            let total: f64 = timings.sequential_total().as_secs_f64();
            let steps: Vec<String> =
                timings.0.iter().map(|(s, t)| format!("{s} {:.0}", t.as_secs_f64() * 1e3)).collect();
            let revealed = revealed.map(|r| format!(", revealed {:.1}%", r * 100.0)).unwrap_or_default();
            say!("frame {frame}: {:.1} ms ({}){revealed}", total * 1e3, steps.join(", "));
        }
    }
    Ok(())
}

fn run_serve(args: ServeArgs) -> anyhow::Result<()> {
    let options = cubist::serve::Options { budget: args.cache_memory << 20, parent: args.parent, ..Default::default() };
    let stdin = std::io::stdin().lock();
    cubist::serve::serve(stdin, Box::new(std::io::stdout()), options)?;
    Ok(())
}

fn run_saliency(args: SaliencyArgs) -> anyhow::Result<()> {
    let settings = args.settings.resolve(args.config.as_deref())?;
    let output = match (&args.output, args.json) {
        (Some(o), _) => Some(o.clone()),
        (None, true) => None,
        (None, false) => Some(std::path::PathBuf::from("saliency.png")),
    };
    if let Some(o) = &output {
        cubist::output::check_png_path(o)?;
    }
    let progress = progress_for(args.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.scene.as_deref(), pipeline::params::load_options(&settings))?;
    let mut stages = Vec::new();
    if let Some(o) = &output {
        let r = pipeline::saliency_map(&prep, &settings, &progress)?;
        write_png(o, &r.image)?;
        for w in &r.warnings {
            say!("warning: {w}");
        }
        if args.verbose {
            say!("camera: {}", r.camera);
        }
        stages.extend(r.timings.0);
    }
    if args.json {
        let t = std::time::Instant::now();
        let json = cubist::saliency::vertex_json(&prep.scene, &prep.saliency, &pipeline::params::saliency(&settings))?;
        stages.push(("vertex saliency", t.elapsed()));
        emit(&serde_json::to_string(&json)?)?;
    }
    progress.begin(Stage::Done.name(), 1);
    progress.finish();
    if args.verbose {
        say!(
            "scene: {} ({} triangles, {} meshes)",
            prep.scene.source.display(),
            prep.world.triangle_count(),
            prep.scene.meshes.len()
        );
        say!("{:>16}: {:>9.1} ms", "load+bvh", prep.build_time.as_secs_f64() * 1e3);
        for (stage, t) in &stages {
            say!("{stage:>16}: {:>9.1} ms", t.as_secs_f64() * 1e3);
        }
    }
    Ok(())
}

/// Parses `KIND[:DEG]`.
fn parse_view(s: &str) -> anyhow::Result<(CameraKind, Option<f64>)> {
    use clap::ValueEnum;
    let (kind, angle) = match s.split_once(':') {
        Some((k, a)) => {
            (k, Some(a.trim().parse::<f64>().with_context(|| format!("view `{s}`: `{a}` is not a number of degrees"))?))
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

fn run_faces(args: FacesArgs) -> anyhow::Result<()> {
    let base = args.settings.resolve(args.config.as_deref())?;
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
        emit(&serde_json::to_string_pretty(
            &serde_json::json!({ "width": base.width, "height": base.height, "spp": base.spp, "rows": rows }),
        )?)?;
    } else {
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
        emit(&table)?;
    }
    Ok(())
}

fn run_settings(args: SettingsCmdArgs) -> anyhow::Result<()> {
    if args.schema {
        return emit(&serde_json::to_string_pretty(&cubist::cli::schema())?);
    }
    let settings = args.settings.resolve(args.config.as_deref())?;
    if args.stages {
        let plan = Plan::new(&StageParams::new(&settings));
        let names: Vec<&str> = plan.stages().iter().map(|s| s.name()).collect();
        return emit(&serde_json::to_string(&names)?);
    }
    emit(&serde_json::to_string_pretty(&settings)?)
}

/// Prints `text` and a newline on stdout. A reader that went away (`cubist settings | head`)
/// ends the output quietly instead of panicking like `println!`.
fn emit(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

fn run_facets(args: FacetsArgs) -> anyhow::Result<()> {
    let settings = args.settings.resolve(args.config.as_deref())?;
    cubist::output::check_png_path(&args.output)?;
    let progress = progress_for(args.progress);
    progress.begin(Stage::Loading.name(), 1);
    let prep = Prepared::load_with(args.scene.as_deref(), pipeline::params::load_options(&settings))?;
    let out = pipeline::inspect_facets(&prep, &settings, &progress)?;
    progress.begin(Stage::Writing.name(), 1);
    let mut outputs = Outputs::new();
    outputs.png(&args.output, &out.view)?;
    for (name, img) in &out.images {
        outputs.png(&pass_path(&args.output, name), img)?;
    }
    let map;
    if let Some(path) = &settings.save_facets {
        map = out.layout.rasterize(settings.width, settings.height);
        cubist::facets::io::add_to(&mut outputs, path, &out.layout, &map)?;
    }
    outputs.commit()?;
    progress.begin(Stage::Done.name(), 1);
    progress.finish();
    for w in &out.warnings {
        say!("warning: {w}");
    }
    if args.verbose {
        for l in &out.levels.levels {
            let chosen = l.selected.iter().filter(|s| **s).count();
            say!(
                "level N={}: {} segments, {} selected (mean saliency >= {})",
                l.requested,
                l.count,
                chosen,
                l.threshold
            );
        }
        say!("superpixels: {}, facets: {}", out.levels.superpixel_count, out.layout.facet_count);
        let steps = out.timings.0.iter().map(|(s, t)| (s.to_string(), *t));
        for (stage, t) in steps.chain(out.levels.timings.iter().cloned()) {
            say!("{stage:>14}: {:>9.1} ms", t.as_secs_f64() * 1e3);
        }
    }
    Ok(())
}

fn run_look(mut args: LookArgs) -> anyhow::Result<()> {
    // The look's targets are stated at 640 x 480.
    args.settings.width = args.settings.width.or(Some(640));
    args.settings.height = args.settings.height.or(Some(480));
    let after = args.settings.resolve(args.config.as_deref())?;
    let before = args.before.map(|p| {
        let mut s = cubist::settings::Settings::preset(p);
        (s.width, s.height, s.spp, s.seed) = (after.width, after.height, after.spp, after.seed);
        s
    });
    if let Some(sheet) = &args.sheet
        && !sheet.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("jpg"))
    {
        cubist::output::check_png_path(sheet)?;
    }
    // (name, a file, or a scene built in code; None and None: the still life).
    let mut scenes: Vec<(String, Option<std::path::PathBuf>, Option<cubist::scene::Scene>)> =
        cubist::look::scene_files(&args.scenes)?
            .into_iter()
            .map(|p| (cubist::look::scene_name(Some(&p)), Some(p), None))
            .collect();
    if args.still_life || (scenes.is_empty() && !args.odd) {
        scenes.push((cubist::look::scene_name(None), None, None));
    }
    if args.odd {
        scenes.extend(cubist::look::odd::odd_scenes().into_iter().map(|(n, s)| (n, None, Some(s))));
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
                let mut s = settings.clone();
                (s.width, s.height) = (size, size);
                let mut times: Vec<f64> = Vec::new();
                for _ in 0..args.time_runs.max(1) {
                    let t = std::time::Instant::now();
                    pipeline::render(&prep, &s, &Progress::silent())?;
                    times.push(t.elapsed().as_secs_f64() * 1e3);
                }
                times.sort_by(f64::total_cmp);
                look.row.time_big_ms = Some(times[times.len() / 2]);
            }
            eprintln!("{name}: fill {:.0}%, straight {:.1}%", 100.0 * look.row.fill, 100.0 * look.row.straight);
            rows.push(look.row);
            pics.push(look.image);
        }
        pictures.push(pics);
    }
    if let Some(sheet) = &args.sheet {
        let rows: Vec<Vec<&image::RgbaImage>> = pictures.iter().map(|p| p.iter().collect()).collect();
        let columns = if before.is_some() { 2 } else { 4 };
        let img = cubist::look::contact_sheet(&rows, 240, columns);
        // A .jpg sheet keeps the committed report small (the PNG of 80 thumbnails is ~5 MB).
        if sheet.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("jpg")) {
            let rgb = image::DynamicImage::ImageRgba8(img).to_rgb8();
            let out = std::io::BufWriter::new(std::fs::File::create(sheet)?);
            image::codecs::jpeg::JpegEncoder::new_with_quality(out, 85).encode_image(&rgb)?;
        } else {
            write_png(sheet, &img)?;
        }
    }
    if args.json {
        emit(&serde_json::to_string_pretty(
            &serde_json::json!({ "width": after.width, "height": after.height, "before": rows_before, "after": rows_after, "skipped": skipped }),
        )?)?;
    } else {
        let mut text = String::new();
        if let Some(p) = args.before {
            text += &format!("Before (`--preset {p}`):\n\n{}\nAfter:\n\n", cubist::look::markdown(&rows_before));
        }
        text += &cubist::look::markdown(&rows_after);
        for s in &skipped {
            text += &format!("\nskipped: {s}");
        }
        emit(&text)?;
    }
    Ok(())
}
