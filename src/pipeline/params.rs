//! The one place that reads the validated `Settings` for the stages: each stage gets its own
//! parameters, in its own types, and nothing else (so a stage can be run, tested and, later,
//! cached on exactly what it depends on). A new setting is read here and nowhere else.

use crate::camera;
use crate::facets::motion::FacetMotion;
use crate::facets::segment::{SegmentParams, SegmentWeights};
use crate::facets::{self, FacetMethod, FacetParams};
use crate::framing::{self, FramingParams};
use crate::imprecision::{AimMode, AimParams, FacetProjection};
use crate::output::Pass;
use crate::paint::borders::BorderParams;
use crate::paint::brushwork::BrushworkParams;
use crate::paint::canvas::CanvasGrainParams;
use crate::paint::chiaroscuro::ChiaroscuroParams;
use crate::paint::contours::ContourParams;
use crate::paint::gradients::GradientParams;
use crate::paint::palette::PaletteParams;
use crate::paint::passage::PassageParams;
use crate::paint::plane_light::PlaneLightParams;
use crate::paint::quantise::QuantiseParams;
use crate::paint::silhouettes::SilhouetteParams;
use crate::paint::values::ValueParams;
use crate::paint::{BorderStyle, PaintParams, Palette};
use crate::saliency::{SaliencyMethod, SaliencyParams};
use crate::settings::{self, Settings};
use crate::trace::TraceParams;

// The settings' bounds on facets (16-bit ids) and image size are the facets' own; both modules
// state them, this module knows both.
const _: () = assert!(settings::MAX_FACETS == facets::MAX_FACETS);
const _: () = assert!(settings::MAX_PIXELS == facets::MAX_BASE_PIXELS);
const _: () = assert!(settings::MAX_PLANES == facets::planes::MAX_PLANES);

/// Every stage's parameters for one render.
#[derive(Clone, Debug, PartialEq)]
pub struct StageParams {
    pub framing: FramingParams,
    pub trace: TraceParams,
    pub saliency: SaliencyParams,
    pub facets: FacetParams,
    pub aim: AimParams,
    pub paint: PaintParams,
    /// Extra images written beside the output, in the settings' order.
    pub passes: Vec<Pass>,
    /// Where the facet layout used is saved, for reuse by later frames.
    pub save_facets: Option<std::path::PathBuf>,
    /// How facets move between animation frames.
    pub motion: FacetMotion,
}

impl StageParams {
    /// The parameters of every stage from validated settings.
    pub fn new(s: &Settings) -> StageParams {
        StageParams {
            framing: framing(s),
            trace: trace(s),
            saliency: saliency(s),
            facets: facets(s),
            aim: aim(s),
            paint: paint(s),
            passes: s.passes.iter().map(|&p| pass(p)).collect(),
            save_facets: s.save_facets.clone(),
            motion: facet_motion(s.facet_motion),
        }
    }

    /// Whether any stage reads the scene's mesh saliency: re-aiming at saliency centres,
    /// Segment faceting (unless a saved layout replaces it), and the passes that show it.
    pub fn needs_saliency(&self) -> bool {
        let imprecision_uses = self.facets.faceted() && self.aim.reads_saliency();
        let segment_uses = matches!(self.facets.method, FacetMethod::Segment | FacetMethod::Planes)
            && self.facets.layout_file.is_none();
        imprecision_uses || segment_uses || self.passes.contains(&Pass::Saliency) || self.passes.contains(&Pass::Facets)
    }
}

pub fn framing(s: &Settings) -> FramingParams {
    FramingParams {
        kind: camera_kind(s.camera),
        ambiguity: s.ambiguity,
        framing: match s.framing {
            settings::Framing::Fit => framing::Framing::Fit,
            settings::Framing::Centre => framing::Framing::Centre,
            settings::Framing::Compose => framing::Framing::Compose,
        },
        focus_distance: s.focus_distance,
        position: s.camera_position,
        target: s.camera_target,
        up: s.camera_up,
        size: s.camera_size,
        fill: s.fill,
        width: s.width,
        height: s.height,
    }
}

pub fn camera_kind(k: settings::CameraKind) -> camera::CameraKind {
    use camera::CameraKind as C;
    match k {
        settings::CameraKind::Auto => C::Auto,
        settings::CameraKind::Spherical => C::Spherical,
        settings::CameraKind::Cylindrical => C::Cylindrical,
        settings::CameraKind::Planar => C::Planar,
        settings::CameraKind::Perspective => C::Perspective,
        settings::CameraKind::Orthographic => C::Orthographic,
    }
}

pub fn facet_motion(m: settings::FacetMotion) -> FacetMotion {
    match m {
        settings::FacetMotion::Static => FacetMotion::Static,
        settings::FacetMotion::Follow => FacetMotion::Follow,
    }
}

pub fn trace(s: &Settings) -> TraceParams {
    TraceParams {
        width: s.width,
        height: s.height,
        spp: s.spp,
        aa_threshold: s.aa_threshold,
        seed: s.seed,
        shadows: s.shadows,
        exposure: s.exposure,
        background: s.background,
    }
}

pub fn saliency(s: &Settings) -> SaliencyParams {
    SaliencyParams {
        method: saliency_method(s.saliency_method),
        cache: s.saliency_cache.clone(),
        parts: s.part_saliency as f32,
    }
}

pub fn saliency_method(m: settings::SaliencyMethod) -> SaliencyMethod {
    match m {
        settings::SaliencyMethod::Auto => SaliencyMethod::Auto,
        settings::SaliencyMethod::Exact => SaliencyMethod::Exact,
        settings::SaliencyMethod::Clustered => SaliencyMethod::Clustered,
    }
}

pub fn facets(s: &Settings) -> FacetParams {
    FacetParams {
        method: match s.faceting {
            settings::Faceting::None => FacetMethod::None,
            settings::Faceting::Constant => FacetMethod::Constant,
            settings::Faceting::Voronoi => FacetMethod::Voronoi,
            settings::Faceting::Patch => FacetMethod::Patch,
            settings::Faceting::Segment => FacetMethod::Segment,
            settings::Faceting::Planes => FacetMethod::Planes,
        },
        layout_file: s.facets.clone(),
        facet_map: s.facet_map.clone(),
        facet_count: s.facet_count,
        grid_cells: s.grid_cells,
        patch_count: s.patch_count,
        occlusion: s.occlusion,
        segment: segment(s),
        planes: facets::planes::PlanesParams {
            planes: s.planes,
            detail: s.plane_detail,
            outlines: s.plane_outlines,
            seed: s.seed,
        },
        width: s.width,
        height: s.height,
        seed: s.seed,
    }
}

pub fn segment(s: &Settings) -> SegmentParams {
    SegmentParams {
        segments: s.segments.clone(),
        thresholds: s.thresholds.clone(),
        superpixels: s.superpixels,
        weights: SegmentWeights {
            colour: s.weight_colour as f32,
            normal: s.weight_normal as f32,
            depth: s.weight_depth as f32,
            object: s.weight_object as f32,
            saliency: s.weight_saliency as f32,
        },
        seed: s.seed,
    }
}

pub fn aim(s: &Settings) -> AimParams {
    AimParams {
        mode: match s.imprecision {
            settings::Imprecision::Saliency => AimMode::Saliency,
            settings::Imprecision::Random => AimMode::Random,
            settings::Imprecision::None => AimMode::None,
        },
        projection: match s.facet_projection {
            settings::FacetProjection::Converging => FacetProjection::Converging,
            settings::FacetProjection::Linear => FacetProjection::Linear,
        },
        discontinuity: s.discontinuity,
        neighborhood: s.neighborhood,
        facet_fov: s.facet_fov,
        scale: s.pixel_scale(),
        seed: s.seed,
        min_coverage: s.aim_min_coverage,
        width_share: s.aim_width_share,
        view_turn: s.view_turn,
    }
}

pub fn paint(s: &Settings) -> PaintParams {
    let (scale, seed) = (s.pixel_scale(), s.seed);
    // The planes faceting leaves some planes whole across the outline (passage).
    let open_planes = s.faceting == settings::Faceting::Planes && s.plane_outlines;
    let borders = BorderParams {
        width: s.border_width,
        strength: s.border_strength,
        style: match s.border_style {
            settings::BorderStyle::Symmetric => BorderStyle::Symmetric,
            settings::BorderStyle::Passage => BorderStyle::Passage,
        },
        scale,
        seed,
        open_planes,
    };
    let brushwork =
        BrushworkParams { opacity: s.brushwork, length: s.stroke_length, width: s.stroke_width, scale, seed };
    PaintParams {
        chiaroscuro: ChiaroscuroParams { amount: s.chiaroscuro, seed },
        silhouettes: SilhouetteParams { width: s.silhouette_width, strength: s.silhouette_strength, scale },
        borders: borders.clone(),
        gradients: GradientParams { fraction: s.gradients, seed },
        palette: PaletteParams {
            palette: match s.palette {
                settings::Palette::None => Palette::None,
                settings::Palette::Ochre => Palette::Ochre,
                settings::Palette::OchreGrey => Palette::OchreGrey,
                settings::Palette::Grey => Palette::Grey,
                settings::Palette::BluePeriod => Palette::BluePeriod,
                settings::Palette::Olive => Palette::Olive,
            },
            image: s.palette_image.clone(),
            seed,
            ground_value: s.ground_value,
        },
        quantise: QuantiseParams { colors: s.colors },
        plane_light: PlaneLightParams { amount: s.plane_light, seed, steps: s.light_steps },
        contours: ContourParams { width: s.contour_width, strength: s.contour_strength, scale, seed },
        passage: PassageParams(borders),
        brushwork,
        values: ValueParams { contrast: s.value_contrast, lift: s.value_lift },
        canvas_grain: CanvasGrainParams { amount: s.canvas_grain, scale, seed },
        open_planes,
        background: s.background,
        transparent: s.transparent,
    }
}

/// How the scene file may reach other files (README "Security").
pub fn load_options(s: &Settings) -> crate::scene::LoadOptions {
    crate::scene::LoadOptions { allow_external_files: s.allow_external_files }
}

/// The mesh saliency a render of `s` will compute, to start it beside the BVH build
/// (`Prepared::load_for_render`); None when the render needs none, or when the settings are
/// invalid (the render itself then reports them).
pub fn mesh_saliency_ahead(s: &Settings) -> Option<SaliencyParams> {
    s.validate().ok()?;
    let params = StageParams::new(s);
    super::Plan::new(&params).saliency.then_some(params.saliency)
}

/// A still has no next frame: the `motion` pass is for animation frames only.
pub fn check_still_passes(s: &Settings) -> crate::error::Result<()> {
    if s.passes.contains(&settings::Pass::Motion) {
        return Err(crate::error::Error::setting(
            "pass",
            "the motion pass needs animation frames (render --frames A-B)",
        ));
    }
    Ok(())
}

pub fn pass(p: settings::Pass) -> Pass {
    match p {
        settings::Pass::Saliency => Pass::Saliency,
        settings::Pass::Facets => Pass::Facets,
        settings::Pass::FacetIds => Pass::FacetIds,
        settings::Pass::Segments => Pass::Segments,
        settings::Pass::Objects => Pass::Objects,
        settings::Pass::Normals => Pass::Normals,
        settings::Pass::Depth => Pass::Depth,
        settings::Pass::Motion => Pass::Motion,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_enum_value_keeps_its_name() {
        use clap::ValueEnum;
        for &k in settings::CameraKind::value_variants() {
            assert_eq!(camera_kind(k).as_str(), k.as_str());
        }
        for &m in settings::SaliencyMethod::value_variants() {
            assert_eq!(saliency_method(m).as_str(), m.as_str(), "the saliency cache keys on this name");
        }
        for &p in settings::Pass::value_variants() {
            assert_eq!(pass(p).as_str(), p.as_str());
        }
    }

    #[test]
    fn saliency_is_needed_exactly_when_a_stage_reads_it() {
        let base = Settings {
            faceting: settings::Faceting::None,
            imprecision: settings::Imprecision::Saliency,
            discontinuity: 0.0,
            passes: vec![],
            ..Settings::default()
        };
        let needs = |s: Settings| StageParams::new(&s).needs_saliency();
        assert!(!needs(base.clone()));
        assert!(!needs(Settings { discontinuity: 100.0, ..base.clone() }), "no facets to re-aim");
        let voronoi = Settings { faceting: settings::Faceting::Voronoi, discontinuity: 100.0, ..base.clone() };
        assert!(needs(voronoi.clone()));
        assert!(!needs(Settings { imprecision: settings::Imprecision::Random, ..voronoi }));
        assert!(needs(Settings { faceting: settings::Faceting::Segment, ..base.clone() }));
        assert!(needs(Settings { passes: vec![settings::Pass::Saliency], ..base.clone() }));
        assert!(needs(Settings { passes: vec![settings::Pass::Facets], ..base.clone() }));
        // A loaded layout replaces the segmentation; re-aiming still needs saliency.
        let loaded = Some(std::path::PathBuf::from("/l.json"));
        assert!(!needs(Settings { faceting: settings::Faceting::Segment, facets: loaded.clone(), ..base.clone() }));
        assert!(needs(Settings { facets: loaded, discontinuity: 50.0, ..base }));
    }
}
