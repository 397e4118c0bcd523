//! Every setting as an optional flag, and the layer the flags given make.
//!
//! `SettingsArgs` mirrors `Settings`: each flag serialises under the same key as the JSON
//! config, so flags, config file and presets merge in one place (`Settings::from_layers`).

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;
use serde_json::{Map, Value};

use crate::error::Result;
use crate::settings::{
    BorderStyle, CameraKind, FacetMotion, FacetProjection, Faceting, Framing, Imprecision, Palette, Pass, Preset,
    SaliencyMethod, Settings,
};

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
    /// Samples per pixel of the final image, stratified (the pre-render traces each pixel's centre once) [default: 4]
    #[arg(long, help_heading = "Image")]
    pub spp: Option<u32>,
    /// Seed of every random choice [default: 0]
    #[arg(long, help_heading = "Image")]
    pub seed: Option<u64>,
    /// Adaptive anti-aliasing: only pixels differing from a neighbour by more than this (sRGB 0..1), or showing another object, get --spp samples; 0 = all pixels [default: 0.05]
    #[arg(long, value_name = "DIFFERENCE", help_heading = "Image", value_parser = finite_f32)]
    pub aa_threshold: Option<f32>,

    /// Camera model [default: auto = spherical, or cylindrical for tall scenes]
    #[arg(long, value_enum, help_heading = "Camera")]
    pub camera: Option<CameraKind>,
    /// Convergence angle of cubist cameras, degrees (spherical/cylindrical 0..360, planar 0..<180); vertical field of view of the perspective camera [default: chosen per scene by --framing compose (at most 160), 140 under fit and centre; perspective: the glTF camera's or 60]
    #[arg(long, help_heading = "Camera", allow_negative_numbers = true, value_parser = finite_f64)]
    pub ambiguity: Option<f64>,
    /// Where the focal centre goes without --focus-distance: compose = as close behind the scene as the cameras allow, with the horizontal and vertical spans fitted so the subject fills the canvas; fit = behind the scene so all of it spans --fill of 140 deg; centre = the bounding box's centre [default: compose]
    #[arg(long, value_enum, help_heading = "Camera")]
    pub framing: Option<Framing>,
    /// Distance from the camera position to the focal centre along the view, scene units [default: chosen by --framing]
    #[arg(long, help_heading = "Camera", allow_negative_numbers = true, value_parser = finite_f64)]
    pub focus_distance: Option<f64>,
    /// Camera position X,Y,Z, scene units [default: the glTF camera's, else in front (+Z) of the scene]
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1,
        value_name = "X,Y,Z",
        help_heading = "Camera",
        allow_hyphen_values = true,
        value_parser = finite_f64
    )]
    pub camera_position: Option<Vec<f64>>,
    /// Point looked at X,Y,Z, scene units [default: the glTF camera's view, else the scene's centre]
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1,
        value_name = "X,Y,Z",
        help_heading = "Camera",
        allow_hyphen_values = true,
        value_parser = finite_f64
    )]
    pub camera_target: Option<Vec<f64>>,
    /// Camera up vector X,Y,Z [default: the glTF camera's, else 0,1,0]
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1,
        value_name = "X,Y,Z",
        help_heading = "Camera",
        allow_hyphen_values = true,
        value_parser = finite_f64
    )]
    pub camera_up: Option<Vec<f64>>,
    /// Planar plane height / orthographic view height / cylindrical band height, scene units [default: fits the scene]
    #[arg(long, help_heading = "Camera", allow_negative_numbers = true, value_parser = finite_f64)]
    pub camera_size: Option<f64>,
    /// Fraction of the view the scene fills under automatic framing, (0, 1]: of each span under compose, of the convergence half-angles under fit, of the smaller image side for perspective/orthographic [default: 0.94 compose, 0.8 fit, 0.9 others]
    #[arg(long, help_heading = "Camera", value_parser = finite_f64)]
    pub fill: Option<f64>,

    /// Cast shadow rays (true/false) [default: true]
    #[arg(long, help_heading = "Shading")]
    pub shadows: Option<bool>,
    /// Background colour R,G,B, linear, 0..1 [default: 0.34,0.3,0.24]
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "R,G,B", help_heading = "Shading", value_parser = finite_f32)]
    pub background: Option<Vec<f32>>,
    /// Transparent background (alpha 0) [default: false]
    #[arg(long, num_args = 0..=1, default_missing_value = "true", help_heading = "Shading")]
    pub transparent: Option<bool>,
    /// Multiplier on the automatically exposed lights [default: 1]
    #[arg(long, help_heading = "Shading", value_parser = finite_f32)]
    pub exposure: Option<f32>,

    /// Faceting method; planes tile the canvas with straight-edged planes cut along the subject's outlines, segment is the thesis's (both need saliency) [analytic: planes]
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
    #[arg(long, help_heading = "Facets", value_parser = finite_f64)]
    pub occlusion: Option<f64>,
    /// Segment: segments per level, comma-separated [default: 5,30,120]
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "N,...", help_heading = "Facets")]
    pub segments: Option<Vec<u32>>,
    /// Segment: mean-saliency threshold per level, 0..1 [default: 0,0.05,0.08]
    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "T,...", help_heading = "Facets", value_parser = finite_f64)]
    pub thresholds: Option<Vec<f64>>,
    /// Segment: superpixels the normalized cut groups; 0 = automatic [default: 0]
    #[arg(long, help_heading = "Facets")]
    pub superpixels: Option<u32>,
    /// Segment: weight of colour differences in the segmentation's affinity [default: 1]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)]
    pub weight_colour: Option<f64>,
    /// Segment: weight of surface normal differences [default: 1]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)]
    pub weight_normal: Option<f64>,
    /// Segment: weight of relative depth differences [default: 0.5]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)]
    pub weight_depth: Option<f64>,
    /// Segment: how far object boundaries cut the affinity, 0..1; 1 = segments never cross objects [default: 0.9]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)]
    pub weight_object: Option<f64>,
    /// Segment: weight of saliency differences [default: 0.5]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)]
    pub weight_saliency: Option<f64>,
    /// Planes: how many planes the canvas is split into before the subject's outlines cut them [default: 90]
    #[arg(long, help_heading = "Facets")]
    pub planes: Option<u32>,
    /// Planes: how much denser planes are at the most salient parts than far from the subject, 1..100 [default: 12]
    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)]
    pub plane_detail: Option<f64>,
    /// Planes: cut the planes along the subject's outlines (true/false) [default: true]
    #[arg(long, help_heading = "Facets")]
    pub plane_outlines: Option<bool>,

    /// How facets are re-aimed [default: saliency]
    #[arg(long, value_enum, help_heading = "Spatial imprecision")]
    pub imprecision: Option<Imprecision>,
    /// Largest facet-centre to saliency-centre shift, pixels at 1000 px; the paper recommends 50-200 [analytic: 110]
    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)]
    pub discontinuity: Option<f64>,
    /// Re-aim a facet only when this share of its pixels showed geometry, 0..1; 0 = every facet, as the thesis [analytic: 0.5]
    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)]
    pub aim_min_coverage: Option<f64>,
    /// Largest view shift of a re-aimed facet, as a share of its mean width; 0 = only --discontinuity limits it [analytic: 0.3]
    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)]
    pub aim_width_share: Option<f64>,
    /// Pixels outside a facet that count for its saliency centre, at 1000 px [default: 0]
    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)]
    pub neighborhood: Option<f64>,
    /// Rays of a re-aimed facet: converging on its new focal point, or linear (eq 4.6) [default: converging]
    #[arg(long, value_enum, help_heading = "Spatial imprecision")]
    pub facet_projection: Option<FacetProjection>,
    /// Field of view of linear facets, degrees (eq 4.7); 0 = orthographic facets [default: 0]
    #[arg(long, help_heading = "Spatial imprecision", value_parser = finite_f64)]
    pub facet_fov: Option<f64>,

    /// Facet border darkening distance md (eq 4.8), pixels at 1000 px; 0 = off [analytic: 7]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub border_width: Option<f64>,
    /// Facet border darkening strength, 0..1; 1 = eq 4.8 as printed [analytic: 0.95]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub border_strength: Option<f64>,
    /// Background darkening distance around the objects, pixels at 1000 px; 0 = off [analytic: 0]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub silhouette_width: Option<f64>,
    /// Silhouette darkening strength, 0..1 [analytic: 0.5]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub silhouette_strength: Option<f64>,
    /// Built-in palette mapped onto the luminance ranks [analytic: ochre-grey]
    #[arg(long, value_enum, help_heading = "Painterly effects")]
    pub palette: Option<Palette>,
    /// A painting (PNG/JPEG, any size) whose colours are mapped onto the luminance ranks; overrides --palette
    #[arg(long, value_name = "IMAGE", help_heading = "Painterly effects")]
    pub palette_image: Option<PathBuf>,
    /// Quantise to K colours by luminance; 0 = off [analytic: 0]
    #[arg(long, value_name = "K", help_heading = "Painterly effects")]
    pub colors: Option<u32>,
    /// Fraction of facets with a gradient overlay on a corner, 0..1 [analytic: 0]
    #[arg(long, value_name = "FRACTION", help_heading = "Painterly effects", value_parser = finite_f64)]
    pub gradients: Option<f64>,
    /// Per-facet relighting, its lights turned towards the plane's lit side, 0..1; 0 = off [analytic: 0.3]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub chiaroscuro: Option<f64>,
    /// Light-to-dark ramp across each facet, each plane lit on its own, 0..1; 0 = off [analytic: 0.8]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub plane_light: Option<f64>,
    /// Facet borders: symmetric (eq 4.8 on both sides) or passage (one side, lost and found, silhouettes too) [analytic: passage]
    #[arg(long, value_enum, help_heading = "Painterly effects")]
    pub border_style: Option<BorderStyle>,
    /// Opacity of the brush-stroke layer, 0..1; 0 = off [analytic: 0.85]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub brushwork: Option<f64>,
    /// Brush stroke length, pixels at 1000 px [default: 30]
    #[arg(long, value_name = "PX", help_heading = "Painterly effects", value_parser = finite_f64)]
    pub stroke_length: Option<f64>,
    /// Brush stroke width, pixels at 1000 px [default: 8]
    #[arg(long, value_name = "PX", help_heading = "Painterly effects", value_parser = finite_f64)]
    pub stroke_width: Option<f64>,
    /// Canvas weave showing through the paint, 0..1; 0 = off [analytic: 0.5]
    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)]
    pub canvas_grain: Option<f64>,

    /// How mesh saliency's Gaussian means are evaluated [default: auto]
    #[arg(long, value_enum, help_heading = "Saliency")]
    pub saliency_method: Option<SaliencyMethod>,
    /// Directory keeping per-mesh saliency across runs, keyed by mesh content (created if missing)
    #[arg(long, value_name = "DIR", help_heading = "Saliency")]
    pub saliency_cache: Option<PathBuf>,

    /// How facets move over animation frames: static = the layout frame's facets stay on the image (the thesis); follow = each surface point keeps its facet, carried with the scene's motion [default: static]
    #[arg(long, value_enum, help_heading = "Animation")]
    pub facet_motion: Option<FacetMotion>,

    /// Extra image written beside the output as <stem>.<pass>.png; repeat for several
    #[arg(long = "pass", value_enum, help_heading = "Outputs")]
    #[serde(rename = "passes", skip_serializing_if = "Vec::is_empty")]
    pub pass: Vec<Pass>,

    /// Let the scene's image and buffer URIs name files outside its folder (absolute paths, ../); off by default, so an untrusted scene reads nothing else on the machine (README "Security") [default: false]
    #[arg(long, num_args = 0..=1, default_missing_value = "true", help_heading = "Security")]
    pub allow_external_files: Option<bool>,
}

/// A flag's number: finite, so that NaN or infinity is an error naming the flag (never read
/// as "automatic"; JSON has no NaN).
pub(crate) fn finite_f64(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("not a number ({e})"))?;
    if v.is_finite() { Ok(v) } else { Err("not a finite number".into()) }
}

/// `finite_f64` for the settings kept as f32 (exposure, background): finite as f32 too.
fn finite_f32(s: &str) -> std::result::Result<f32, String> {
    let v = finite_f64(s)?;
    let f = v as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        Err(format!("{} is beyond the range of this setting", crate::error::short_num(v)))
    }
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
