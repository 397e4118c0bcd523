//! The command line (clap definitions: raw flags), their conversion into validated
//! `Settings` (`settings_args`), the schema of every setting for front ends (`schema`), and
//! each subcommand's body (`commands`).

pub mod commands;
pub mod frames;
mod schema;
mod settings_args;

use std::path::PathBuf;

use crate::error::Result;
use crate::settings::{Preset, Settings};
use clap::{Args, Parser, Subcommand, ValueEnum};

pub use schema::schema;
pub use settings_args::SettingsArgs;

#[derive(Parser, Debug)]
#[command(
    name = "cubist",
    version,
    about = "Renders 3D scenes in the manner of Analytical Cubism: cubist cameras, facets, mesh saliency, painterly effects",
    after_help = "Pixel-valued settings (discontinuity, neighborhood, border and silhouette widths) are given at 1000 px and scale with sqrt(width x height) / 1000.\nExit codes: 0 success, 1 bad input or failure, 2 bad usage (flags, settings)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene (the built-in still life when none is given) to a PNG.
    Render(RenderArgs),
    /// Count the faces visible through one or more cameras (the thesis's Table 4.1 measure).
    Faces(FacesArgs),
    /// Write the saliency map seen through the camera (grey PNG) and/or print per-vertex mesh saliency as JSON.
    Saliency(SaliencyArgs),
    /// Compute a scene's Segment facet layout and write it as images: <stem>.png the
    /// pre-render, <stem>.layout.png the facets; with --pass segments also the superpixels and
    /// each level (<stem>.level1.png...), as in the thesis's Fig. 4.5.
    Facets(FacetsArgs),
    /// Print the fully resolved, validated settings as JSON on stdout: every key, with the
    /// preset's values and the defaults, after the config file and the flags (null = chosen
    /// per scene, see each flag's help). Nothing is rendered. With --schema, what every
    /// setting is (for front ends); with --stages, the stages a render of these settings runs.
    Settings(SettingsCmdArgs),
    /// The look report: render each scene, measure straight planes,
    /// whole-canvas planes, subject fill, ghosts, cues kept and per-plane light, print a
    /// markdown table (or JSON) and write a contact sheet. Default size 640 x 480.
    Look(LookArgs),
    /// Keep running and render on request: JSON lines on stdin, one reply per line on stdout
    /// (docs/serve.md). The scene, its BVH, saliency and every stage's output are kept between
    /// requests, so a change re-runs only the stages it invalidates. Ends on `shutdown`, at the
    /// end of stdin, or when the parent process dies.
    Serve(ServeArgs),
}

#[derive(Args, Debug)]
pub struct LookArgs {
    /// Scenes (.glb/.gltf) or folders of them (their .glb/.gltf files, not recursive).
    pub scenes: Vec<PathBuf>,
    /// Include the built-in still life (always when no scene is given).
    #[arg(long)]
    pub still_life: bool,
    /// Include the built-in odd scenes: very tall, very flat, z-up, several objects, a walking
    /// figure, a pole, a board edge-on, a bench, far from the origin, huge, tiny, objects on a
    /// floor, a room modelled as one closed box around the camera.
    #[arg(long)]
    pub odd: bool,
    /// Also render every scene with this preset: measured and shown beside, as "before".
    #[arg(long, value_enum, value_name = "PRESET")]
    pub before: Option<Preset>,
    /// Write a contact sheet here (.png, or .jpg): per scene, the before picture (with --before) and the after one.
    #[arg(long, value_name = "PNG")]
    pub sheet: Option<PathBuf>,
    /// Print JSON rows instead of markdown tables.
    #[arg(long)]
    pub json: bool,
    /// Also time every render at SIZE x SIZE pixels (the median of --time-runs).
    #[arg(long, value_name = "SIZE")]
    pub time_size: Option<u32>,
    /// Renders timed per scene with --time-size.
    #[arg(long, default_value_t = 3)]
    pub time_runs: u32,
    #[command(flatten)]
    pub settings: SettingsSource,
}

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Memory the kept stage outputs may use, MiB (the image size in use is always kept).
    #[arg(long, value_name = "MIB", default_value_t = crate::pipeline::DEFAULT_BUDGET >> 20)]
    pub cache_memory: u64,
    /// The process id of the program driving the server: the server ends when that process
    /// is no longer its parent (Unix; elsewhere the end of stdin ends it) [default: the parent at start]
    #[arg(long, value_name = "PID")]
    pub parent: Option<u32>,
}

/// A command's settings: a JSON file of them (`--config`) and every setting's flag, which
/// overrides the file. The file's help is this one unless a command words it its own way.
#[derive(Args, Debug)]
pub struct SettingsSource {
    /// JSON file of settings, as for `render`.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub flags: SettingsArgs,
}

impl SettingsSource {
    /// The validated settings: the preset's, then the file's, then the flags'.
    pub fn resolve(&self) -> Result<Settings> {
        self.flags.resolve(self.config.as_deref())
    }
}

/// What a command that renders reads and how it reports its run: the scene, `--verbose` and
/// `--progress`. Placed after `SettingsSource`, so `--config` lists before `--verbose`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Scene (.gltf or .glb). Without one, the built-in still life.
    pub scene: Option<PathBuf>,
    /// Print the camera used and each stage's time.
    #[arg(short, long)]
    pub verbose: bool,
    #[arg(long, value_enum, default_value = "auto")]
    pub progress: ProgressMode,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// A progress bar when stderr is a terminal, nothing otherwise.
    Auto,
    /// Always a progress bar.
    Bar,
    /// Machine-readable lines on stderr: `PROGRESS <fraction 0..1> <stage>` (the Blender add-on reads these).
    Lines,
    /// Nothing.
    None,
}

// The frames' flags come before the settings' so their "Animation" heading lists first.
#[derive(Args, Debug)]
#[command(
    mut_arg("scene", |a| a.help("Scene to render (.gltf or .glb). Without one, the built-in still life")),
    mut_arg("config", |a| a.help("JSON file of settings (the keys of the options below, in snake_case); flags override it")),
)]
pub struct RenderArgs {
    /// Output image (.png). Passes go beside it as <stem>.<pass>.png.
    #[arg(short, long, default_value = "cubist.png")]
    pub output: PathBuf,
    #[command(flatten)]
    pub frames: FramesArgs,
    #[command(flatten)]
    pub settings: SettingsSource,
    #[command(flatten)]
    pub run: RunArgs,
}

/// Animation frames of `render` (README "Animation"); the range, `--frames`, is a setting
/// (`Settings::frames`), and these need it.
#[derive(Args, Debug, Default)]
pub struct FramesArgs {
    /// Frames per second: frame f is the animation at (f - N) / fps seconds, N from --frame-at-zero
    #[arg(long, default_value_t = crate::pipeline::DEFAULT_FPS, requires = "frames", help_heading = "Animation", value_parser = settings_args::finite_f64)]
    pub fps: f64,
    /// The frame shown at the animation's time 0: 1, Blender's first frame; 0 for a file
    /// Blender exported with its defaults (it writes its frame f at f / fps seconds unless "Set
    /// All glTF Animation Starting at 0" is on), so frame numbers match Blender's timeline
    #[arg(long, value_name = "N", default_value_t = 1, requires = "frames", help_heading = "Animation")]
    pub frame_at_zero: u32,
    /// The glTF animation played, by name or index, or `all` of them at once [default: the first,
    /// with every later one of other nodes (Blender exports one per object), if any]
    #[arg(long, value_name = "NAME|INDEX|all", requires = "frames", help_heading = "Animation")]
    pub animation: Option<String>,
    /// Turntable: the camera turns this many degrees per frame about the scene's vertical axis
    /// (through its centre; positive turns it counter-clockwise seen from above); only the
    /// camera moves (and the default lights, which follow it)
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 0.0,
        allow_negative_numbers = true,
        requires = "frames",
        value_parser = settings_args::finite_f64,
        help_heading = "Animation"
    )]
    pub orbit: f64,
    /// The frame the facet layout is made at, which also fixes the camera's framing
    #[arg(long, value_name = "N", default_value_t = 1, requires = "frames", help_heading = "Animation")]
    pub layout_frame: u32,
    /// With --facet-motion follow: a new key frame every N frames from the layout frame, its
    /// facets carried from the one before (points the layout frame did not see keep the facet
    /// they grew into); 0 = the layout frame only [default: with --orbit, every 30 degrees of
    /// turn; else 0]
    #[arg(long, value_name = "N", requires = "frames", help_heading = "Animation")]
    pub rekey: Option<u32>,
}

#[derive(Args, Debug)]
#[command(mut_arg("config", |a| a.help("JSON settings file, as for `render`")))]
pub struct SaliencyArgs {
    /// Saliency map image (.png, grey, white = most salient) [default: saliency.png, none with --json]
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print every mesh's per-vertex saliency, in the glTF's vertex order, as JSON on stdout:
    /// {"meshes": [{"name": ..., "vertex_saliency": [...]}, ...]}
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub settings: SettingsSource,
    #[command(flatten)]
    pub run: RunArgs,
}

#[derive(Args, Debug)]
#[command(mut_arg("config", |a| a.help("JSON settings file, as for `render`")))]
pub struct FacesArgs {
    /// Scenes to evaluate (.gltf or .glb); one row per scene and view.
    #[arg(required = true)]
    pub scenes: Vec<PathBuf>,
    /// A camera setting to evaluate, as KIND or KIND:DEGREES (e.g. planar:90, spherical:360,
    /// perspective:60, orthographic). Repeat for a whole table row. Without any, the camera
    /// and angles of --camera and --ambiguity.
    #[arg(long = "view", value_name = "KIND[:DEG]")]
    pub views: Vec<String>,
    /// Several angles for --camera, degrees, comma-separated (e.g. 90,120,150).
    #[arg(long, value_delimiter = ',', value_name = "DEG,...")]
    pub angles: Vec<f64>,
    /// Print JSON instead of a table (with each view's camera in scene units).
    #[arg(long)]
    pub json: bool,
    /// With --json, also list the visible triangle ids of each view.
    #[arg(long, requires = "json")]
    pub ids: bool,
    #[command(flatten)]
    pub settings: SettingsSource,
}

#[derive(Args, Debug)]
#[command(mut_arg("verbose", |a| a.help("Print each step's time and each level's segment count")))]
pub struct FacetsArgs {
    /// Output image (.png): the pre-render; the layout and levels go beside it.
    #[arg(short, long, default_value = "facets.png")]
    pub output: PathBuf,
    #[command(flatten)]
    pub settings: SettingsSource,
    #[command(flatten)]
    pub run: RunArgs,
}

#[derive(Args, Debug)]
#[command(mut_arg("config", |a| a.help("JSON file of settings, as for `render`; flags override it")))]
pub struct SettingsCmdArgs {
    #[command(flatten)]
    pub settings: SettingsSource,
    /// Print instead every setting's type, default (the analytic preset's), range or choices,
    /// unit, help and group, the pipeline's stages and the presets, as JSON (README, "The
    /// settings schema"). The other options are ignored.
    #[arg(long, conflicts_with = "stages")]
    pub schema: bool,
    /// Print instead the stages a render of these settings runs, in order, as a JSON list of
    /// their progress names (`re-trace` runs only if some facet's rays move).
    #[arg(long)]
    pub stages: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: `--camera-position -2,1,2.5` was refused as an unknown flag `-2`.
    #[test]
    fn vectors_may_start_with_a_minus_sign() {
        let cli = Cli::try_parse_from([
            "cubist",
            "faces",
            "a.glb",
            "--camera-position",
            "-2,1,2.5",
            "--camera-target",
            "-0.5,-1,0",
            "--camera-up",
            "-1,0,0",
        ])
        .unwrap();
        let Command::Faces(args) = cli.command else { panic!("not faces") };
        let s = args.settings.resolve().unwrap();
        assert_eq!(s.camera_position, Some([-2.0, 1.0, 2.5]));
        assert_eq!(s.camera_target, Some([-0.5, -1.0, 0.0]));
        assert_eq!(s.camera_up, Some([-1.0, 0.0, 0.0]));
    }
}
