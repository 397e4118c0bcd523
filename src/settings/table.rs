//! Every setting, declared once: `settings_table!` lists each key with its type and doc, its
//! value before any preset, its schema entry (kind, unit, range, choices), how its range is
//! checked and its flag (clap attributes and help). From it come `Settings` with
//! `Settings::base`, `FIELDS` (the schema, `settings::schema`) and the range checks
//! (`Settings::check_ranges`, here), and `SettingsArgs`, the flags (`cli::settings_args`).
//!
//! Adding a setting is one entry here and the stage parameter that reads it
//! (`pipeline::params`). A preset's values stay in `presets` (a bundle of values, not a
//! declaration); checks that involve several keys stay in `validate`.
//!
//! Why a `macro_rules!` table and no crate: the entries must feed serde, clap's derive and the
//! schema at once, with clap's attributes passed through as written. A declarative macro does
//! that with the derives the crate already uses (ripgrep declares its flags in one table the
//! same way); the crates that generate config structs own the whole loading path instead
//! (files, environment, their own CLI layer), and would replace the layers and messages that
//! `layers` and `validate` define.
//!
//! An entry (`settings_table!` passes the whole list to the macro it is given):
//!
//! ```text
//! /// Doc of the `Settings` field.
//! key: Type = value before any preset,
//!     schema field(Kind).unit(..).range(..).choices(..),
//!     check Message("{v} must be ..."),    // optional: the message of a value outside the
//!                                           // range (default IN_RANGE); ByHand: `validate`
//!     flag "Help of --key [default: ..]"
//!         #[arg(long, help_heading = "..", ..)] Option<FlagType>;
//! ```

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::schema::Kind::{Array, Boolean, Enum, Integer, Number, Path, Text};
use super::schema::{
    DEGREES, DISTANCE_PX, FACETS, Field, LINEAR_RGB, NON_NEGATIVE, PX, PX_AT_1000, Range, SCENE_LENGTH, SCENE_POINT,
    SCENE_UNITS, SIDE, UNIT, WEIGHT, choices, field,
};
use super::validate::Check::{ByHand, Message};
use super::validate::{
    IN_RANGE, MAX_EXPOSURE, MAX_GRID_CELLS, MAX_OCCLUSION, MAX_PLANES, MAX_SEGMENTS, MAX_SUPERPIXELS, in_range,
};
use super::{
    BorderStyle, CameraKind, FacetMotion, FacetProjection, Faceting, Framing, Imprecision, Palette, Pass, Preset,
    SaliencyMethod,
};
use crate::error::Result;

/// The table: passes every entry to `$then!`, which matches an entry as the module doc shows.
macro_rules! settings_table {
    ($then:ident) => {
        $then! {
            /// The preset the other values started from.
            preset: Preset = Preset::Plain,
                schema field(Enum).choices(choices::<Preset>),
                flag "Bundle of defaults the other options override (docs/presets.md lists their values) [default: analytic]"
                    #[arg(long, value_enum, help_heading = "Settings")] Option<Preset>;

            // ---- image and sampling
            /// Output width, pixels.
            width: u32 = 800,
                schema field(Integer).unit(PX).range(SIDE),
                check ByHand,
                flag "Image width, pixels [default: 800]"
                    #[arg(long, help_heading = "Image")] Option<u32>;

            /// Output height, pixels.
            height: u32 = 600,
                schema field(Integer).unit(PX).range(SIDE),
                check ByHand,
                flag "Image height, pixels [default: 600]"
                    #[arg(long, help_heading = "Image")] Option<u32>;

            /// Samples per pixel of the final image (stratified, seeded); the pre-render that facets
            /// and saliency read traces one, at each pixel's centre.
            spp: u32 = 4,
                schema field(Integer).range(Range::at_least(1.0)),
                check Message("must be at least {min}"),
                flag "Samples per pixel of the final image, stratified (the pre-render traces each pixel's centre once) [default: 4]"
                    #[arg(long, help_heading = "Image")] Option<u32>;

            /// Seed of every random choice (sampling, facets, gradients).
            seed: u64 = 0,
                schema field(Integer).range(NON_NEGATIVE),
                flag "Seed of every random choice [default: 0]"
                    #[arg(long, help_heading = "Image")] Option<u64>;

            // ---- sampling
            /// Adaptive anti-aliasing: only pixels that differ from a neighbour of their facet by
            /// more than this (sRGB, 0..1, any channel), or show another object, get `spp` samples;
            /// the others keep their centre sample. 0: every pixel gets `spp`.
            aa_threshold: f32 = 0.05,
                // 13 of 255 sRGB codes: from 0.02 (5 codes) to 0.05, the PSNR against 64 spp on
                // every pixel moved by at most 0.2 dB on eight scenes (pixels off by > 8 codes:
                // +0.01-0.02% of the canvas) while anti-aliasing's rays fell by 25-45%: below 13
                // codes a neighbour's difference is mostly shading and texture gradient, which
                // more samples do not change (BENCHMARKS.md).
                schema field(Number).range(UNIT),
                check Message("must be in {range} (an sRGB difference; 0 = every pixel)"),
                flag "Adaptive anti-aliasing: only pixels differing from a neighbour by more than this (sRGB 0..1), or showing another object, get --spp samples; 0 = all pixels [default: 0.05]"
                    #[arg(long, value_name = "DIFFERENCE", help_heading = "Image", value_parser = finite_f32)] Option<f32>;

            // ---- camera
            camera: CameraKind = CameraKind::Auto,
                schema field(Enum).choices(choices::<CameraKind>),
                flag "Camera model [default: auto = spherical, or cylindrical for tall scenes]"
                    #[arg(long, value_enum, help_heading = "Camera")] Option<CameraKind>;

            /// Convergence angle of cubist cameras, degrees; the vertical field of view of the
            /// perspective camera. None: 140 for cubist cameras, 60 (or the glTF camera's) for perspective.
            ambiguity: Option<f64> = None,
                // Planar cameras: [0, 180); perspective: (0, 180).
                schema field(Number).nullable().unit(DEGREES).range(Range::closed(0.0, 360.0)),
                check ByHand,
                flag "Convergence angle of cubist cameras, degrees (spherical/cylindrical 0..360, planar 0..<180); vertical field of view of the perspective camera [default: chosen per scene by --framing compose (at most 160), 140 under fit and centre; perspective: the glTF camera's or 60]"
                    #[arg(long, help_heading = "Camera", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            framing: Framing = Framing::Fit,
                schema field(Enum).choices(choices::<Framing>),
                flag "Where the focal centre goes without --focus-distance: compose = as close behind the scene as the cameras allow, with the horizontal and vertical spans fitted so the subject fills the canvas; fit = behind the scene so all of it spans --fill of 140 deg; centre = the bounding box's centre [default: compose]"
                    #[arg(long, value_enum, help_heading = "Camera")] Option<Framing>;

            /// Distance from the camera position to the focal centre along the view direction,
            /// scene units. None: chosen by `framing`.
            focus_distance: Option<f64> = None,
                schema field(Number).nullable().unit(SCENE_UNITS).range(SCENE_LENGTH),
                check Message("{v} must be a positive distance up to {max:e}"),
                flag "Distance from the camera position to the focal centre along the view, scene units [default: chosen by --framing]"
                    #[arg(long, help_heading = "Camera", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Camera position, scene units. None: the glTF scene's camera, else in front (+Z) of the scene.
            camera_position: Option<[f64; 3]> = None,
                schema field(Array).of(Number).length(3).nullable().unit(SCENE_UNITS).range(SCENE_POINT),
                check Message("must be three finite numbers within +-{max:e}"),
                flag "Camera position X,Y,Z, scene units [default: the glTF camera's, else in front (+Z) of the scene]"
                    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "X,Y,Z", help_heading = "Camera", allow_hyphen_values = true, value_parser = finite_f64)] Option<Vec<f64>>;

            /// Point the camera looks at, scene units. None: the glTF camera's view, else the scene's centre.
            camera_target: Option<[f64; 3]> = None,
                schema field(Array).of(Number).length(3).nullable().unit(SCENE_UNITS).range(SCENE_POINT),
                check Message("must be three finite numbers within +-{max:e}"),
                flag "Point looked at X,Y,Z, scene units [default: the glTF camera's view, else the scene's centre]"
                    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "X,Y,Z", help_heading = "Camera", allow_hyphen_values = true, value_parser = finite_f64)] Option<Vec<f64>>;

            /// Camera up vector. None: the glTF camera's up, else +Y.
            camera_up: Option<[f64; 3]> = None,
                schema field(Array).of(Number).length(3).nullable().range(SCENE_POINT),
                check Message("must be a finite, non-zero vector"),
                flag "Camera up vector X,Y,Z [default: the glTF camera's, else 0,1,0]"
                    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "X,Y,Z", help_heading = "Camera", allow_hyphen_values = true, value_parser = finite_f64)] Option<Vec<f64>>;

            /// Planar camera plane height / orthographic view height / cylindrical band height,
            /// scene units. None: fits the scene.
            camera_size: Option<f64> = None,
                schema field(Number).nullable().unit(SCENE_UNITS).range(SCENE_LENGTH),
                check Message("{v} must be a positive distance up to {max:e}"),
                flag "Planar plane height / orthographic view height / cylindrical band height, scene units [default: fits the scene]"
                    #[arg(long, help_heading = "Camera", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Fraction of the view the scene fills when the camera is framed automatically: of the
            /// convergence half-angles for cubist cameras (measured on the image plane, i.e. in
            /// tan(angle), for the planar camera), of the smaller image side for perspective and
            /// orthographic cameras. None: 0.8 for cubist cameras, 0.9 for the others.
            fill: Option<f64> = None,
                schema field(Number).nullable().range(UNIT.open_min()),
                check Message("{v} must be in {range}"),
                flag "Fraction of the view the scene fills under automatic framing, (0, 1]: of each span under compose, of the convergence half-angles under fit, of the smaller image side for perspective/orthographic [default: 0.94 compose, 0.8 fit, 0.9 others]"
                    #[arg(long, help_heading = "Camera", value_parser = finite_f64)] Option<f64>;

            // ---- shading
            /// Cast one shadow ray per light per hit.
            shadows: bool = true,
                schema field(Boolean),
                flag "Cast shadow rays (true/false) [analytic: false; the other presets: true]"
                    #[arg(long, help_heading = "Shading")] Option<bool>;

            /// Background colour, linear RGB in [0, 1].
            background: [f32; 3] = [0.62, 0.56, 0.46],
                schema field(Array).of(Number).length(3).unit(LINEAR_RGB).range(Range::closed(0.0, MAX_EXPOSURE)),
                check Message("must be three numbers in {range}"),
                flag "Background colour R,G,B, linear, 0..1 [default: 0.21,0.18,0.14]"
                    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "R,G,B", help_heading = "Shading", value_parser = finite_f32)] Option<Vec<f32>>;

            /// Background alpha 0 in the output PNG.
            transparent: bool = false,
                schema field(Boolean),
                flag "Transparent background (alpha 0) [default: false]"
                    #[arg(long, num_args = 0..=1, default_missing_value = "true", help_heading = "Shading")] Option<bool>;

            /// Multiplier on the lights, after the automatic exposure that makes any light units work.
            exposure: f32 = 1.0,
                schema field(Number).range(Range::closed(0.0, MAX_EXPOSURE)),
                flag "Multiplier on the automatically exposed lights [default: 1]"
                    #[arg(long, help_heading = "Shading", value_parser = finite_f32)] Option<f32>;

            // ---- facets
            faceting: Faceting = Faceting::None,
                schema field(Enum).choices(choices::<Faceting>),
                flag "Faceting method; planes tile the canvas with straight-edged planes cut along the subject's outlines, segment is the thesis's (both need saliency) [analytic: planes]"
                    #[arg(long, value_enum, help_heading = "Facets")] Option<Faceting>;

            /// Facet map image for `constant` faceting.
            facet_map: Option<PathBuf> = None,
                schema field(Path).nullable(),
                flag "Facet map image for constant faceting, each distinct colour a facet"
                    #[arg(long, value_name = "PNG", help_heading = "Facets")] Option<PathBuf>;

            /// Load this facet layout (.json or .png) instead of computing one.
            facets: Option<PathBuf> = None,
                schema field(Path).nullable(),
                flag "Load this facet layout (.json or .png) instead of computing one"
                    #[arg(long, value_name = "FILE", help_heading = "Facets")] Option<PathBuf>;

            /// Save the facet layout used (.json or .png), for reuse across frames.
            save_facets: Option<PathBuf> = None,
                schema field(Path).nullable(),
                flag "Save the facet layout used (.json or .png) for reuse across frames"
                    #[arg(long, value_name = "FILE", help_heading = "Facets")] Option<PathBuf>;

            /// Voronoi: number of facets k.
            facet_count: u32 = 150,
                schema field(Integer).range(FACETS),
                check Message("must be in {min}..={max}"),
                flag "Voronoi: number of facets k [default: 150]"
                    #[arg(long, help_heading = "Facets")] Option<u32>;

            /// Voronoi: number of grid cells m the k points are stratified over.
            grid_cells: u32 = 15,
                schema field(Integer).range(Range::closed(1.0, MAX_GRID_CELLS as f64)),
                check Message("must be in {min}..={max}"),
                flag "Voronoi: grid cells m the points are stratified over [default: 15]"
                    #[arg(long, help_heading = "Facets")] Option<u32>;

            /// Patch: number of quadrilaterals n_p of eq 4.3 (more are added until all is covered).
            patch_count: u32 = 80,
                schema field(Integer).range(FACETS),
                check Message("must be in {min}..={max}"),
                flag "Patch: number of quadrilaterals n_p (eq 4.3) [default: 80]"
                    #[arg(long, help_heading = "Facets")] Option<u32>;

            /// Patch: occlusion ratio r_occ of eq 4.3.
            occlusion: f64 = 3.0,
                schema field(Number).range(Range::closed(0.0, MAX_OCCLUSION).open_min()),
                check Message("must be a number in {range}"),
                flag "Patch: occlusion ratio r_occ (eq 4.3) [default: 3]"
                    #[arg(long, help_heading = "Facets", value_parser = finite_f64)] Option<f64>;

            /// Segment: segments per level.
            segments: Vec<u32> = vec![5, 30, 120],
                schema field(Array).of(Integer).range(Range::closed(1.0, MAX_SEGMENTS as f64)),
                check ByHand,
                flag "Segment: segments per level, comma-separated [default: 5,30,120]"
                    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "N,...", help_heading = "Facets")] Option<Vec<u32>>;

            /// Segment: mean-saliency threshold per level, in [0, 1].
            thresholds: Vec<f64> = vec![0.0, 0.05, 0.08],
                schema field(Array).of(Number).range(UNIT),
                flag "Segment: mean-saliency threshold per level, 0..1 [default: 0,0.05,0.08]"
                    #[arg(long, value_delimiter = ',', num_args = 1, value_name = "T,...", help_heading = "Facets", value_parser = finite_f64)] Option<Vec<f64>>;

            /// Segment: superpixels the normalized cut groups; 0 = automatic (see `facets::segment`).
            superpixels: u32 = 0,
                schema field(Integer).range(Range::closed(0.0, MAX_SUPERPIXELS as f64)),
                check Message("at most {max} (0 = automatic)"),
                flag "Segment: superpixels the normalized cut groups; 0 = automatic [default: 0]"
                    #[arg(long, help_heading = "Facets")] Option<u32>;

            /// Segment: weight of colour (CIELAB) differences in the segmentation's affinity.
            weight_colour: f64 = 1.0,
                schema field(Number).range(WEIGHT),
                flag "Segment: weight of colour differences in the segmentation's affinity [default: 1]"
                    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Segment: weight of surface normal differences.
            weight_normal: f64 = 1.0,
                schema field(Number).range(WEIGHT),
                flag "Segment: weight of surface normal differences [default: 1]"
                    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Segment: weight of relative depth differences.
            weight_depth: f64 = 0.5,
                schema field(Number).range(WEIGHT),
                flag "Segment: weight of relative depth differences [default: 0.5]"
                    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Segment: how far object boundaries cut the affinity, in [0, 1]; 1 = segments never
            /// cross an object boundary (a level may then get more than N segments).
            weight_object: f64 = 0.9,
                schema field(Number).range(UNIT),
                flag "Segment: how far object boundaries cut the affinity, 0..1; 1 = segments never cross objects [default: 0.9]"
                    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Segment: weight of saliency differences.
            weight_saliency: f64 = 0.5,
                schema field(Number).range(WEIGHT),
                flag "Segment: weight of saliency differences [default: 0.5]"
                    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            // ---- planes faceting and what facets show (`facets::planes`, `imprecision::guard`)
            /// Planes: how many planes the canvas is split into before the subject's outlines cut them.
            planes: u32 = 150,
                schema field(Integer).range(Range::closed(1.0, MAX_PLANES as f64)),
                check Message("must be in {min}..={max}"),
                flag "Planes: how many planes the canvas is split into before the subject's outlines cut them [default: 90]"
                    #[arg(long, help_heading = "Facets")] Option<u32>;

            /// Planes: how much denser the planes are at the most salient parts than far from the
            /// subject (a ratio of planes per area, >= 1).
            plane_detail: f64 = 5.0,
                schema field(Number).range(Range::closed(1.0, 100.0)),
                check Message("{v} must be in {range}"),
                flag "Planes: how much denser planes are at the most salient parts than far from the subject, 1..100 [default: 12]"
                    #[arg(long, help_heading = "Facets", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Planes: cut the planes along the subject's outlines (silhouettes and object boundaries).
            plane_outlines: bool = true,
                schema field(Boolean),
                flag "Planes: cut the planes along the subject's outlines (true/false) [default: true]"
                    #[arg(long, help_heading = "Facets")] Option<bool>;

            /// A facet is re-aimed only when at least this share of its pixels showed geometry in the
            /// pre-render, in [0, 1]; 0 = every facet (the thesis). Background facets then keep the
            /// backdrop instead of a magnified copy of the subject (a ghost).
            aim_min_coverage: f64 = 0.0,
                schema field(Number).range(UNIT),
                flag "Re-aim a facet only when this share of its pixels showed geometry, 0..1; 0 = every facet, as the thesis [analytic: 0.5]"
                    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// A re-aimed facet's view shifts by at most this share of its mean width (converging
            /// facets), >= 0; 0 = no limit but `discontinuity` (the thesis). Keeps thin parts (an arm,
            /// a finger) in their planes.
            aim_width_share: f64 = 0.0,
                schema field(Number).range(Range::closed(0.0, 100.0)),
                flag "Largest view shift of a re-aimed facet, as a share of its mean width; 0 = only --discontinuity limits it [analytic: 0.3]"
                    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            /// Turn the view of the subject's planes by this many degrees about the camera's up,
            /// each towards its own side of the subject, so the picture shows several sides at
            /// once (a frontal eye beside a profile nose); 0 = off. A plane that holds a cue keeps its
            /// view; a plane is turned only where the turned view still mostly shows the subject.
            view_turn: f64 = 0.0,
                schema field(Number).unit(DEGREES).range(Range::closed(0.0, 90.0)),
                check Message("{v} must be in {range}"),
                flag "Turn each of the subject's planes by this many degrees, so it shows several sides at once; 0 = off [default: 0]"
                    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            // ---- spatial imprecision
            imprecision: Imprecision = Imprecision::Saliency,
                schema field(Enum).choices(choices::<Imprecision>),
                flag "How facets are re-aimed [default: saliency]"
                    // Listed before the aim_ flags of --help (declared above, with the planes).
                    #[arg(long, value_enum, help_heading = "Spatial imprecision", display_order = 0)] Option<Imprecision>;

            /// Largest distance from facet centre to saliency centre, pixels at 1000 px.
            discontinuity: f64 = 0.0,
                schema field(Number).unit(PX_AT_1000).range(DISTANCE_PX),
                flag "Largest facet-centre to saliency-centre shift, pixels at 1000 px; the paper recommends 50-200 [analytic: 110]"
                    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64, display_order = 1)] Option<f64>;

            /// Pixels outside a facet that still count for its saliency centre, pixels at 1000 px.
            neighborhood: f64 = 0.0,
                schema field(Number).unit(PX_AT_1000).range(DISTANCE_PX),
                flag "Pixels outside a facet that count for its saliency centre, at 1000 px [default: 0]"
                    #[arg(long, help_heading = "Spatial imprecision", allow_negative_numbers = true, value_parser = finite_f64)] Option<f64>;

            facet_projection: FacetProjection = FacetProjection::Converging,
                schema field(Enum).choices(choices::<FacetProjection>),
                flag "Rays of a re-aimed facet: converging on its new focal point, or linear (eq 4.6) [default: converging]"
                    #[arg(long, value_enum, help_heading = "Spatial imprecision")] Option<FacetProjection>;

            /// Field of view of linear facets, degrees (eq 4.7); 0 = orthographic facets.
            facet_fov: f64 = 0.0,
                schema field(Number).unit(DEGREES).range(Range::closed(0.0, 180.0).open_max()),
                check Message("{v} must be in {range} degrees"),
                flag "Field of view of linear facets, degrees (eq 4.7); 0 = orthographic facets [default: 0]"
                    #[arg(long, help_heading = "Spatial imprecision", value_parser = finite_f64)] Option<f64>;

            // ---- painterly effects
            /// Facet border darkening distance md of eq 4.8 (with passage, the join's reach: the
            /// line within 0.56 md, the blend within md / 2), pixels at 1000 px; 0 = off.
            border_width: f64 = 0.0,
                schema field(Number).unit(PX_AT_1000).range(DISTANCE_PX),
                flag "Facet border darkening distance md (eq 4.8; passage: the join's reach), pixels at 1000 px; 0 = off [analytic: 7]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// 0 = no darkening, 1 = eq 4.8 as printed.
            border_strength: f64 = 1.0,
                schema field(Number).range(UNIT),
                flag "Facet border darkening strength, 0..1; 1 = eq 4.8 as printed [analytic: 0.95]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Silhouette darkening distance, pixels at 1000 px; 0 = off.
            silhouette_width: f64 = 0.0,
                schema field(Number).unit(PX_AT_1000).range(DISTANCE_PX),
                flag "Background darkening distance around the objects, pixels at 1000 px; 0 = off [analytic: 0]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            silhouette_strength: f64 = 1.0,
                schema field(Number).range(UNIT),
                flag "Silhouette darkening strength, 0..1 [analytic: 0.5]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// The subject's inner contours (parts meeting, depth steps, creases) drawn as a
            /// broken dark line (`paint::contours`): its width, pixels at 1000 px; 0 = off.
            contour_width: f64 = 0.0,
                schema field(Number).unit(PX_AT_1000).range(DISTANCE_PX),
                flag "Width of the line drawn along the subject's inner contours (parts, depth steps, creases), pixels at 1000 px; 0 = off [analytic: 3.4]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            contour_strength: f64 = 1.0,
                schema field(Number).range(UNIT),
                flag "Darkness of the inner contour line, 0..1 [analytic: 0.75]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Built-in palette mapped onto the output's luminance.
            palette: Palette = Palette::None,
                schema field(Enum).choices(choices::<Palette>),
                flag "Built-in palette mapped onto the luminance ranks [analytic: ochre-grey]"
                    #[arg(long, value_enum, help_heading = "Painterly effects")] Option<Palette>;

            /// A painting whose colours are mapped onto the output's luminance (overrides `palette`).
            palette_image: Option<PathBuf> = None,
                schema field(Path).nullable(),
                flag "A painting (PNG/JPEG, any size) whose colours are mapped onto the luminance ranks; overrides --palette"
                    #[arg(long, value_name = "IMAGE", help_heading = "Painterly effects")] Option<PathBuf>;

            /// The share of its luminance the ground (the background and the planes open across
            /// the outline) is ranked at by the palette, in [0.05, 1]: below 1 the subject takes
            /// the lighter part of the palette and the ground the darker (the figure stands out
            /// of its ground); 1 = ranked as rendered.
            ground_value: f64 = 1.0,
                schema field(Number).range(Range::closed(0.05, 1.0)),
                check Message("{v} must be in {range}"),
                flag "The share of its luminance the ground (background, planes open across the outline) is ranked at by the palette, 0.05..1: below 1 the subject takes the palette's lighter part; 1 = as rendered; needs a palette [analytic: 0.6]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Quantise to this many colours; 0 = off.
            colors: u32 = 0,
                // 1 is refused: quantising to one colour leaves no image.
                schema field(Integer).range(Range::closed(0.0, 4096.0)),
                check Message("at most {max}"),
                flag "Quantise to K colours by luminance; 0 = off [analytic: 0]"
                    #[arg(long, value_name = "K", help_heading = "Painterly effects")] Option<u32>;

            /// Fraction of facets that get a gradient overlay on a corner, in [0, 1].
            gradients: f64 = 0.0,
                schema field(Number).range(UNIT),
                flag "Fraction of facets with a gradient overlay on a corner, 0..1 [analytic: 0]"
                    #[arg(long, value_name = "FRACTION", help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Per-facet relighting, each facet's lights turned towards its plane's lit side, in
            /// [0, 1]; 0 = off.
            chiaroscuro: f64 = 0.0,
                schema field(Number).range(UNIT),
                flag "Per-facet relighting, its lights turned towards the plane's lit side, 0..1; 0 = off [analytic: 0.3]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            // ---- per-plane light, passage and brushwork (`paint::plane_light`,
            // `paint::passage`, `paint::brushwork`, `paint::canvas`)
            /// Light-to-dark ramp across each facet (each plane lit on its own), in [0, 1]; 0 = off.
            plane_light: f64 = 0.0,
                schema field(Number).range(UNIT),
                flag "Light-to-dark ramp across each facet, each plane lit on its own, 0..1; 0 = off [analytic: 0.8]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Steps of each plane's light from its light end to its dark end, in straight bands
            /// across the plane (over the strokes' paint); 0 = a smooth ramp.
            light_steps: u32 = 0,
                schema field(Integer).range(Range::closed(0.0, 32.0)),
                check Message("must be in {min}..={max}"),
                flag "Steps of each plane's light, in straight bands across it; 0 = a smooth ramp [analytic: 5]"
                    #[arg(long, help_heading = "Painterly effects")] Option<u32>;

            /// How facet borders are drawn: `symmetric` (eq 4.8) or `passage`.
            border_style: BorderStyle = BorderStyle::Symmetric,
                schema field(Enum).choices(choices::<BorderStyle>),
                flag "Facet borders: symmetric (eq 4.8 on both sides) or passage (one side, lost and found, silhouettes too) [analytic: passage]"
                    #[arg(long, value_enum, help_heading = "Painterly effects")] Option<BorderStyle>;

            /// Opacity of the brush-stroke layer, in [0, 1]; 0 = off.
            brushwork: f64 = 0.0,
                schema field(Number).range(UNIT),
                flag "Opacity of the brush-stroke layer, 0..1; 0 = off [analytic: 0.85]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Brush stroke length, pixels at 1000 px.
            stroke_length: f64 = 26.0,
                schema field(Number).unit(PX_AT_1000).range(Range::closed(0.0, 1000.0).open_min()),
                check Message("{v} must be in {range} pixels at 1000 px"),
                flag "Brush stroke length, pixels at 1000 px [default: 30]"
                    #[arg(long, value_name = "PX", help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Brush stroke width, pixels at 1000 px.
            stroke_width: f64 = 7.0,
                schema field(Number).unit(PX_AT_1000).range(Range::closed(0.0, 1000.0).open_min()),
                check Message("{v} must be in {range} pixels at 1000 px"),
                flag "Brush stroke width, pixels at 1000 px [default: 8]"
                    #[arg(long, value_name = "PX", help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// How far the finished paint's values spread about the middle (darker darks, lighter
            /// lights), in [0, 1]; 0 = off.
            value_contrast: f64 = 0.0,
                schema field(Number).range(UNIT),
                flag "Spread of the paint's values about the middle (darker darks, lighter lights), 0..1; 0 = off [analytic: 0.3]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// The finished paint's values times this factor, in [0.1, 4]: above 1 a lighter key
            /// (order and ratios kept below white); 1 = off.
            value_lift: f64 = 1.0,
                schema field(Number).range(Range::closed(0.1, 4.0)),
                check Message("{v} must be in {range}"),
                flag "The paint's values times this factor, after their spread, 0.1..4: above 1 a lighter key; 1 = off [analytic: 1.4]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            /// Canvas weave showing through the paint, in [0, 1]; 0 = off.
            canvas_grain: f64 = 0.0,
                schema field(Number).range(UNIT),
                flag "Canvas weave showing through the paint, 0..1; 0 = off [analytic: 0.5]"
                    #[arg(long, help_heading = "Painterly effects", value_parser = finite_f64)] Option<f64>;

            // ---- saliency
            /// Weight of the subject's small separate parts in the saliency map, in [0, 1]: a part
            /// modelled as a mesh of its own (an eye, a beak, a valve cap) has no saliency of its
            /// own mesh's, so the planes would neither gather at it nor keep it whole.
            part_saliency: f64 = 0.0,
                schema field(Number).range(UNIT),
                check Message("{v} must be in {range}"),
                flag "Weight of the subject's small separate parts (an eye, a beak, a valve cap modelled as meshes of their own, which mesh saliency scores 0) in the saliency map, 0..1; 0 = mesh saliency alone, the thesis [analytic, braque, blue-period, grisaille: 0.5]"
                    #[arg(long, help_heading = "Saliency", value_parser = finite_f64)] Option<f64>;

            saliency_method: SaliencyMethod = SaliencyMethod::Auto,
                schema field(Enum).choices(choices::<SaliencyMethod>),
                flag "How mesh saliency's Gaussian means are evaluated [default: auto]"
                    #[arg(long, value_enum, help_heading = "Saliency")] Option<SaliencyMethod>;

            /// Directory keeping per-mesh saliency across runs, keyed by mesh content (animation
            /// frames rendered by separate processes compute each mesh once). None: no disk cache.
            saliency_cache: Option<PathBuf> = None,
                schema field(Path).nullable(),
                flag "Directory keeping per-mesh saliency across runs, keyed by mesh content (created if missing)"
                    #[arg(long, value_name = "DIR", help_heading = "Saliency")] Option<PathBuf>;

            // ---- animation (frames of `cubist render --frames`, or one per process from the add-on)
            /// Frames `A-B` (inclusive) or one frame `N` of the scene's animation, all rendered in one
            /// process by `cubist render` (`frame_range`). None: a still. The add-on never sends it:
            /// Blender renders one frame per process.
            frames: Option<String> = None,
                schema field(Text).nullable(),
                flag "Render frames A-B of the scene's animation (or one frame N), all in this process; -o names each frame with a run of # for its number (frames/cubist_####.png -> frames/cubist_0001.png...)"
                    // First under its heading, before the frame options of `render` (`cli::FramesArgs`).
                    #[arg(long, value_name = "A-B", help_heading = "Animation", display_order = 0)] Option<String>;

            /// How facets move from frame to frame: `static` keeps the layout frame's facets on the
            /// image, `follow` carries them with the surfaces they show (a saved layout then has its
            /// follow data beside it, `<layout>.follow`).
            facet_motion: FacetMotion = FacetMotion::Static,
                schema field(Enum).choices(choices::<FacetMotion>),
                flag "How facets move over animation frames: static = the layout frame's facets stay on the image (the thesis); follow = each surface point keeps its facet, carried with the scene's motion [default: static]"
                    #[arg(long, value_enum, help_heading = "Animation")] Option<FacetMotion>;

            // ---- outputs
            /// Extra passes written beside the output as `<stem>.<pass>.png`.
            passes: Vec<Pass> = Vec::new(),
                schema field(Array).of(Enum).choices(choices::<Pass>),
                flag "Extra image written beside the output as <stem>.<pass>.png; repeat for several"
                    #[arg(long = "pass", value_name = "PASS", value_enum, help_heading = "Outputs")] #[serde(skip_serializing_if = "Vec::is_empty")] Vec<Pass>;

            // ---- inputs (README "Security")
            /// Let the scene's image and buffer URIs name files outside its folder (absolute paths,
            /// `../`). Off: a scene rendered on a farm reads nothing but its own folder.
            allow_external_files: bool = false,
                schema field(Boolean),
                flag "Let the scene's image and buffer URIs name files outside its folder (absolute paths, ../); off by default, so an untrusted scene reads nothing else on the machine (README \"Security\") [default: false]"
                    #[arg(long, num_args = 0..=1, default_missing_value = "true", help_heading = "Security")] Option<bool>;
        }
    };
}
pub(crate) use settings_table;

/// The settings' side of the table: the struct, its values before any preset, the schema and
/// the range checks.
macro_rules! declare_settings {
    ($(
        $(#[doc = $doc:literal])*
        $key:ident : $ty:ty = $base:expr,
            schema $schema:expr,
            $(check $check:expr,)?
            flag $help:literal $(#[$attr:meta])* $flag:ty;
    )*) => {
        /// Every setting of a render. Defaults are the `analytic` preset's; see `Preset::apply`.
        #[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
        #[serde(deny_unknown_fields, default)]
        pub struct Settings {
            $($(#[doc = $doc])* pub $key: $ty,)*
        }

        impl Settings {
            /// Values before any preset: the bare cubist camera.
            pub(super) fn base() -> Self {
                Settings { $($key: $base,)* }
            }

            /// Checks every value against its key's declared range, in the table's order.
            pub(super) fn check_ranges(&self) -> Result<()> {
                $(in_range(stringify!($key), &self.$key, ($schema).range, [$($check,)? IN_RANGE][0])?;)*
                Ok(())
            }
        }

        /// Every key of `Settings`, in its order.
        pub const FIELDS: &[Field] = &[$(($schema).key(stringify!($key)),)*];
    };
}

settings_table!(declare_settings);
