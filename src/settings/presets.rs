//! What each preset sets: a bundle of values over `Settings::base` (the values before any
//! preset, the bare cubist camera, declared with each key in `table`). The defaults of
//! `Settings` are the `analytic` preset's.

use super::{BorderStyle, CameraKind, Faceting, Framing, Palette, Preset, Settings};

impl Default for Settings {
    fn default() -> Self {
        let mut s = Settings::base();
        Preset::Analytic.apply(&mut s);
        s
    }
}

impl Settings {
    /// The settings of a preset, before any override.
    pub fn preset(preset: Preset) -> Self {
        let mut s = Settings::base();
        preset.apply(&mut s);
        s
    }
}

impl Preset {
    /// Sets the values this preset bundles.
    pub fn apply(self, s: &mut Settings) {
        s.preset = self;
        match self {
            Preset::Plain => {}
            Preset::Thesis => {
                // The thesis's recommendations (Chapter 5): ambiguity 120-150, discontinuity
                // 50-200 at 1000 px, Segment faceting, bold facet borders, a painter's palette.
                s.camera = CameraKind::Auto;
                s.ambiguity = None; // 140 for cubist cameras
                s.framing = Framing::Fit;
                s.faceting = Faceting::Segment;
                s.aim_min_coverage = 0.0;
                s.aim_width_share = 0.0;
                s.discontinuity = 200.0;
                s.border_width = 12.0;
                s.border_strength = 0.85;
                s.silhouette_width = 40.0;
                s.silhouette_strength = 0.5;
                s.palette = Palette::Ochre;
                s.gradients = 0.3;
                s.colors = 0;
                s.chiaroscuro = 0.0;
            }
            Preset::Analytic => {
                // Our look: planes, composition, the backdrop kept still; the
                // thesis's discontinuity 200 at 1000 px, bold borders, a painter's palette.
                planes_look(s);
                // Fewer, larger planes away from the salient parts (a hierarchy), re-aimed
                // less, so the subject keeps its cues; firm, narrow joins.
                s.planes = 90;
                s.plane_detail = 12.0;
                // A dark ground: the palette's ranks put the lit subject over umbers and
                // greys, as the 1910 canvases' central light over a darker ground.
                s.background = [0.21, 0.18, 0.14];
                s.discontinuity = 110.0;
                s.border_width = 7.0;
                s.border_strength = 0.95;
                // Passage draws the silhouettes (no halo); the planes' own ramps replace the
                // corner gradients.
                s.silhouette_width = 0.0;
                s.silhouette_strength = 0.5;
                s.palette = Palette::OchreGrey;
                // The palette ranks the ground at 0.6 of its value, so a dark part of the
                // subject (a brown bowl, a wooden handle) stands out of a ground of its own
                // value (judged blind, round 63).
                s.ground_value = 0.6;
                s.gradients = 0.0;
                s.colors = 0;
                s.chiaroscuro = 0.3;
                // Each plane lit on its own, passage, brushwork.
                s.plane_light = 0.8;
                s.light_steps = 5;
                // No cast shadows: each plane has its own light, not one lamp's in space
                // (judged blind, round 28).
                s.shadows = false;
                s.border_style = BorderStyle::Passage;
                s.brushwork = 0.85;
                s.stroke_length = 30.0;
                s.stroke_width = 8.0;
                s.value_contrast = 0.3;
                // A lighter key over it: the darks stay deep against the lit planes, the
                // whole no longer umber murk (judged blind, round 66).
                s.value_lift = 1.4;
                s.canvas_grain = 0.5;
            }
            Preset::Braque => {
                planes_look(s);
                s.discontinuity = 150.0;
                s.border_width = 16.0;
                s.border_strength = 1.0;
                s.silhouette_width = 20.0;
                s.silhouette_strength = 0.5;
                s.palette = Palette::Olive;
                s.gradients = 0.3;
                s.colors = 8;
                s.chiaroscuro = 0.5;
                // Heavier paint: broad strokes over the eight colours, so they read as paint,
                // not a print.
                s.plane_light = 0.6;
                s.border_style = BorderStyle::Passage;
                s.brushwork = 0.9;
                s.stroke_length = 30.0;
                s.stroke_width = 9.0;
                s.canvas_grain = 0.6;
            }
            Preset::BluePeriod => {
                planes_look(s);
                s.discontinuity = 100.0;
                s.border_width = 8.0;
                s.border_strength = 0.7;
                s.silhouette_width = 20.0;
                s.silhouette_strength = 0.4;
                s.palette = Palette::BluePeriod;
                s.gradients = 0.2;
                s.colors = 0;
                s.chiaroscuro = 0.25;
                // Softer planes, long thin strokes.
                s.plane_light = 0.5;
                s.border_style = BorderStyle::Passage;
                s.brushwork = 0.7;
                s.stroke_length = 34.0;
                s.stroke_width = 6.0;
                s.canvas_grain = 0.4;
            }
            Preset::Grisaille => {
                planes_look(s);
                s.discontinuity = 200.0;
                s.border_width = 12.0;
                s.border_strength = 0.9;
                s.silhouette_width = 25.0;
                s.silhouette_strength = 0.4;
                s.palette = Palette::Grey;
                s.gradients = 0.2;
                s.colors = 6;
                s.chiaroscuro = 0.3;
                s.plane_light = 0.7;
                s.border_style = BorderStyle::Passage;
                s.brushwork = 0.8;
                s.canvas_grain = 0.6;
            }
        }
    }
}

/// The facet, camera and imprecision values of our presets (every preset but
/// `plain` and `thesis`): planes faceting, the `compose` framing with the angles chosen per
/// scene, background facets not re-aimed and view shifts within a share of each facet's width
/// (`imprecision::guard`), small parts in the saliency map, the inner contours drawn.
fn planes_look(s: &mut Settings) {
    s.camera = CameraKind::Auto;
    s.ambiguity = None;
    s.framing = Framing::Compose;
    s.faceting = Faceting::Planes;
    s.planes = 150;
    s.plane_detail = 5.0;
    s.plane_outlines = true;
    s.aim_min_coverage = 0.5;
    s.aim_width_share = 0.3;
    // The small parts are cues too: mesh saliency cannot see a part modelled on its own
    // (judged blind, rounds 59-60).
    s.part_saliency = 0.5;
    // The subject's inner contours drawn, broken (judged blind, rounds 85-93 and 109).
    s.contour_width = 3.4;
    s.contour_strength = 0.75;
}
