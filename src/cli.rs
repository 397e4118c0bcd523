//! Command-line definitions (clap) and their conversion into validated `Settings`.
//!
//! `SettingsArgs` mirrors `Settings`: each flag serialises under the same key as the JSON
//! config, so flags, config file and presets merge in one place (`Settings::from_layers`).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};
use serde::Serialize;
use serde_json::{Map, Value};

use crate::error::Result;
use crate::settings::{
    BorderStyle, CameraKind, FacetProjection, Faceting, Framing, Imprecision, Palette, Pass, Preset, SaliencyMethod,
    Settings,
};

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
    /// per scene, see each flag's help). Nothing is rendered.
    Settings(SettingsCmdArgs),
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

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene to render (.gltf or .glb). Without one, the built-in still life.
    pub scene: Option<PathBuf>,
    /// Output image (.png). Passes go beside it as <stem>.<pass>.png.
    #[arg(short, long, default_value = "cubist.png")]
    pub output: PathBuf,
    /// JSON file of settings (the keys of the options below, in snake_case); flags override it.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Print the camera used and each stage's time.
    #[arg(short, long)]
    pub verbose: bool,
    #[arg(long, value_enum, default_value = "auto")]
    pub progress: ProgressMode,
    #[command(flatten)]
    pub settings: SettingsArgs,
}

#[derive(Args, Debug)]
pub struct SaliencyArgs {
    /// Scene (.gltf or .glb). Without one, the built-in still life.
    pub scene: Option<PathBuf>,
    /// Saliency map image (.png, grey, white = most salient) [default: saliency.png, none with --json]
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print every mesh's per-vertex saliency, in the glTF's vertex order, as JSON on stdout:
    /// {"meshes": [{"name": ..., "vertex_saliency": [...]}, ...]}
    #[arg(long)]
    pub json: bool,
    /// JSON settings file, as for `render`.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Print the camera used and each stage's time.
    #[arg(short, long)]
    pub verbose: bool,
    #[arg(long, value_enum, default_value = "auto")]
    pub progress: ProgressMode,
    #[command(flatten)]
    pub settings: SettingsArgs,
}

#[derive(Args, Debug)]
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
    /// JSON settings file, as for `render`.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub settings: SettingsArgs,
}

#[derive(Args, Debug)]
pub struct FacetsArgs {
    /// Scene (.gltf or .glb). Without one, the built-in still life.
    pub scene: Option<PathBuf>,
    /// Output image (.png): the pre-render; the layout and levels go beside it.
    #[arg(short, long, default_value = "facets.png")]
    pub output: PathBuf,
    /// JSON file of settings, as for `render`.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Print each step's time and each level's segment count.
    #[arg(short, long)]
    pub verbose: bool,
    #[arg(long, value_enum, default_value = "auto")]
    pub progress: ProgressMode,
    #[command(flatten)]
    pub settings: SettingsArgs,
}

#[derive(Args, Debug)]
pub struct SettingsCmdArgs {
    /// JSON file of settings, as for `render`; flags override it.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    #[command(flatten)]
    pub settings: SettingsArgs,
}

/// Every setting as an optional flag. Keys (after serde) are those of `Settings`; flags not
/// given are left out of the layer, so the config file's or the preset's value stands.
#[serde_with::skip_serializing_none]
#[derive(Args, Serialize, Debug, Default)]
pub struct SettingsArgs {
    /// Bundle of defaults the other options override (docs/presets.md lists their values) [default: analytic]
    #[arg(long, value_enum, help_heading = "Settings")]
    pub preset: Option<Preset>,

    /// Image width, pixels [default: 800]
    #[arg(long, help_heading = "Image")]
    pub width: Option<u32>,
    /// Image height, pixels [default: 600]
    #[arg(long, help_heading = "Image")]
    pub height: Option<u32>,
    /// Samples per pixel, stratified [default: 4]
    #[arg(long, help_heading = "Image")]
    pub spp: Option<u32>,
    /// Seed of every random choice [default: 0]
    #[arg(long, help_heading = "Image")]
    pub seed: Option<u64>,

    /// Camera model [default: auto = spherical, or cylindrical for tall scenes]
    #[arg(long, value_enum, help_heading = "Camera")]
    pub camera: Option<CameraKind>,
    /// Convergence angle of cubist cameras, degrees (spherical/cylindrical 0..360, planar 0..<180); vertical field of view of the perspective camera [default: 140; perspective: the glTF camera's or 60]
    #[arg(long, help_heading = "Camera", allow_negative_numbers = true)]
    pub ambiguity: Option<f64>,
    /// Where the focal centre goes without --focus-distance: fit = behind the scene so all of it is in view, centre = the bounding box's centre [default: fit]
    #[arg(long, value_enum, help_heading = "Camera")]
    pub framing: Option<Framing>,
    /// Distance from the camera position to the focal centre along the view, scene units [default: chosen by --framing]
    #[arg(long, help_heading = "Camera", allow_negative_numbers = true)]
    pub focus_distance: Option<f64>,
    /// Camera position X,Y,Z, scene units [default: the glTF camera's, else in front (+Z) of the scene]
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1,
        value_name = "X,Y,Z",
        help_heading = "Camera",
        allow_hyphen_values = true
    )]
    pub camera_position: Option<Vec<f64>>,
    /// Point looked at X,Y,Z, scene units [default: the glTF camera's view, else the scene's centre]
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1,
        value_name = "X,Y,Z",
        help_heading = "Camera",
        allow_hyphen_values = true
    )]
    pub camera_target: Option<Vec<f64>>,
    /// Camera up vector X,Y,Z [default: the glTF camera's, else 0,1,0]
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1,
        value_name = "X,Y,Z",
        help_heading = "Camera",
        allow_hyphen_values = true
    )]
    pub camera_up: Option<Vec<f64>>,
    /// Planar plane height / orthographic view height / cylindrical band height, scene units [default: fits the scene]
    #[arg(long, help_heading = "Camera", allow_negative_numbers = true)]
    pub camera_size: Option<f64>,
    /// Fraction of the view the scene fills under automatic framing, (0, 1]: of the convergence half-angles for cubist cameras, of the smaller image side for perspective/orthographic [default: 0.8 cubist, 0.9 others]
    #[arg(long, help_heading = "Camera")]
    pub fill: Option<f64>,

    /// Cast shadow rays (true/false) [default: true]
    #[arg(long, help_heading = "Shading")]
    pub shadows: Option<bool>,
    /// Background colour R,G,B, linear, 0..1 [default: 0.62,0.56,0.46]
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "R,G,B", help_heading = "Shading")]
    pub background: Option<Vec<f32>>,
    /// Transparent background (alpha 0) [default: false]
    #[arg(long, num_args = 0..=1, default_missing_value = "true", help_heading = "Shading")]
    pub transparent: Option<bool>,
    /// Multiplier on the automatically exposed lights [default: 1]
    #[arg(long, help_heading = "Shading")]
    pub exposure: Option<f32>,

    /// Faceting method; segment follows the picture's forms (needs saliency) [analytic: segment]
    #[arg(long, value_enum, help_heading = "Facets")]
    pub faceting: Option<Faceting>,
    /// Facet map image for constant faceting, each distinct colour a facet
    #[arg(long, value_name = "PNG", help_heading = "Facets")]
    pub facet_map: Option<PathBuf>,
    /// Load this facet layout (.json or .png) instead of computing one
    #[arg(long, value_name = "FILE", help_heading = "Facets")]
    pub facets: Option<PathBuf>,
    /// Save the facet layout used (.json or .png) for reuse across frames
    #[arg(long, value_name = "FILE", help_heading = "Facets")]
    pub save_facets: Option<PathBuf>,
    /// Voronoi: number of facets k [default: 150]
    #[arg(long, help_heading = "Facets")]
    pub facet_count: Option<u32>,
    /// Voronoi: grid cells m the points are stratified over [default: 15]
    #[arg(long, help_heading = "Facets")]
    pub grid_cells: Option<u32>,
    /// Patch: number of quadrilaterals n_p (eq 4.3) [default: 80]
    #[arg(long, help_heading = "Facets")]
    pub patch_count: Option<u32>,
    /// Patch: occlusion ratio r_occ (eq 4.3) [default: 3]
    #[arg(long, help_heading = "Facets")]
    pub occlusion: Option<f64>,
    /// Segment: segments per level, comma-separated [default: 5,30,120]
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "N,...", help_heading = "Facets")]
    pub segments: Option<Vec<u32>>,
    /// Segment: mean-saliency threshold per level, 0..1 [default: 0,0.05,0.08]
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "T,...", help_heading = "Facets")]
    pub thresholds: Option<Vec<f64>>,
    /// Segment: superpixels the normalized cut groups; 0 = automatic [default: 0]
    #[arg(long, help_heading = "Facets")]
    pub superpixels: Option<u32>,
    /// Segment: weight of colour differences in the segmentation's affinity [default: 1]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true)]
    pub weight_colour: Option<f64>,
    /// Segment: weight of surface normal differences [default: 1]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true)]
    pub weight_normal: Option<f64>,
    /// Segment: weight of relative depth differences [default: 0.5]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true)]
    pub weight_depth: Option<f64>,
    /// Segment: how far object boundaries cut the affinity, 0..1; 1 = segments never cross objects [default: 0.9]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true)]
    pub weight_object: Option<f64>,
    /// Segment: weight of saliency differences [default: 0.5]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true)]
    pub weight_saliency: Option<f64>,

    /// How facets are re-aimed [default: saliency]
    #[arg(long, value_enum, help_heading = "Spatial imprecision")]
    pub imprecision: Option<Imprecision>,
    /// Largest facet-centre to saliency-centre shift, pixels at 1000 px; the paper recommends 50-200 [analytic: 200]
    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true)]
    pub discontinuity: Option<f64>,
    /// Pixels outside a facet that count for its saliency centre, at 1000 px [default: 0]
    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true)]
    pub neighborhood: Option<f64>,
    /// Rays of a re-aimed facet: converging on its new focal point, or linear (eq 4.6) [default: converging]
    #[arg(long, value_enum, help_heading = "Spatial imprecision")]
    pub facet_projection: Option<FacetProjection>,
    /// Field of view of linear facets, degrees (eq 4.7); 0 = orthographic facets [default: 0]
    #[arg(long, help_heading = "Spatial imprecision")]
    pub facet_fov: Option<f64>,

    /// Facet border darkening distance md (eq 4.8), pixels at 1000 px; 0 = off [analytic: 12]
    #[arg(long, help_heading = "Painterly effects")]
    pub border_width: Option<f64>,
    /// Facet border darkening strength, 0..1; 1 = eq 4.8 as printed [analytic: 0.85]
    #[arg(long, help_heading = "Painterly effects")]
    pub border_strength: Option<f64>,
    /// Background darkening distance around the objects, pixels at 1000 px; 0 = off [analytic: 0]
    #[arg(long, help_heading = "Painterly effects")]
    pub silhouette_width: Option<f64>,
    /// Silhouette darkening strength, 0..1 [analytic: 0.5]
    #[arg(long, help_heading = "Painterly effects")]
    pub silhouette_strength: Option<f64>,
    /// Built-in palette mapped onto the luminance ranks [analytic: ochre]
    #[arg(long, value_enum, help_heading = "Painterly effects")]
    pub palette: Option<Palette>,
    /// A painting (PNG/JPEG, any size) whose colours are mapped onto the luminance ranks; overrides --palette
    #[arg(long, value_name = "IMAGE", help_heading = "Painterly effects")]
    pub palette_image: Option<PathBuf>,
    /// Quantise to K colours by luminance; 0 = off [analytic: 0]
    #[arg(long, value_name = "K", help_heading = "Painterly effects")]
    pub colors: Option<u32>,
    /// Fraction of facets with a gradient overlay on a corner, 0..1 [analytic: 0]
    #[arg(long, value_name = "FRACTION", help_heading = "Painterly effects")]
    pub gradients: Option<f64>,
    /// Per-facet relighting, its lights turned towards the plane's lit side, 0..1; 0 = off [analytic: 0.3]
    #[arg(long, help_heading = "Painterly effects")]
    pub chiaroscuro: Option<f64>,
    /// Light-to-dark ramp across each facet, each plane lit on its own, 0..1; 0 = off [analytic: 0.7]
    #[arg(long, help_heading = "Painterly effects")]
    pub plane_light: Option<f64>,
    /// Facet borders: symmetric (eq 4.8 on both sides) or passage (one side, lost and found, silhouettes too) [analytic: passage]
    #[arg(long, value_enum, help_heading = "Painterly effects")]
    pub border_style: Option<BorderStyle>,
    /// Opacity of the brush-stroke layer, 0..1; 0 = off [analytic: 0.8]
    #[arg(long, help_heading = "Painterly effects")]
    pub brushwork: Option<f64>,
    /// Brush stroke length, pixels at 1000 px [default: 26]
    #[arg(long, value_name = "PX", help_heading = "Painterly effects")]
    pub stroke_length: Option<f64>,
    /// Brush stroke width, pixels at 1000 px [default: 7]
    #[arg(long, value_name = "PX", help_heading = "Painterly effects")]
    pub stroke_width: Option<f64>,
    /// Canvas weave showing through the paint, 0..1; 0 = off [analytic: 0.5]
    #[arg(long, help_heading = "Painterly effects")]
    pub canvas_grain: Option<f64>,

    /// How mesh saliency's Gaussian means are evaluated [default: auto]
    #[arg(long, value_enum, help_heading = "Saliency")]
    pub saliency_method: Option<SaliencyMethod>,
    /// Directory keeping per-mesh saliency across runs, keyed by mesh content (created if missing)
    #[arg(long, value_name = "DIR", help_heading = "Saliency")]
    pub saliency_cache: Option<PathBuf>,

    /// Extra image written beside the output as <stem>.<pass>.png; repeat for several
    #[arg(long = "pass", value_enum, help_heading = "Outputs")]
    #[serde(rename = "passes", skip_serializing_if = "Vec::is_empty")]
    pub pass: Vec<Pass>,
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
        let s = args.settings.resolve(None).unwrap();
        assert_eq!(s.camera_position, Some([-2.0, 1.0, 2.5]));
        assert_eq!(s.camera_target, Some([-0.5, -1.0, 0.0]));
        assert_eq!(s.camera_up, Some([-1.0, 0.0, 0.0]));
    }
}
