//! The painterly effects' parameters (`PaintParams`) and the chain they turn on, in its fixed
//! order (see the module doc of `paint`).

use super::palette::{self, Palette};
use super::passage::BorderStyle;

/// What the painterly effects need besides the render. Distances are pixels at 1000 px,
/// converted with `scale` (pixels of this image per such pixel); strengths and fractions in
/// [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub struct PaintParams {
    /// Per-facet variation of light direction and intensity; 0 = off.
    pub chiaroscuro: f64,
    /// Silhouette darkening distance; 0 = off.
    pub silhouette_width: f64,
    pub silhouette_strength: f64,
    /// Facet border darkening distance md of eq 4.8; 0 = off.
    pub border_width: f64,
    pub border_strength: f64,
    /// Fraction of facets with a gradient overlay.
    pub gradients: f64,
    /// A built-in palette mapped onto the luminance ranks.
    pub palette: Palette,
    /// A painting whose colours are mapped instead (overrides `palette`).
    pub palette_image: Option<std::path::PathBuf>,
    /// Quantise to this many colours; 0 = off.
    pub colors: u32,
    /// The light-to-dark ramp across each facet (0 = off), how borders are drawn,
    /// the stroke layer's opacity (0 = off) and stroke size, the canvas weave (0 = off).
    pub plane_light: f64,
    pub border_style: BorderStyle,
    pub brushwork: f64,
    pub stroke_length: f64,
    pub stroke_width: f64,
    pub canvas_grain: f64,
    /// The facets include planes left whole across the subject's outline (the planes
    /// faceting's passage): such a plane is one region for the effects (`PaintContext::regions`).
    pub open_planes: bool,
    pub scale: f64,
    pub seed: u64,
    /// The render's background, linear RGB, and whether the output is transparent.
    pub background: [f32; 3],
    pub transparent: bool,
}

/// One effect of the chain, in chain order (see the module doc for why this order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Step {
    Chiaroscuro,
    Silhouettes,
    Borders,
    Gradients,
    Palette,
    Quantise,
    PlaneLight,
    Brushwork,
    CanvasGrain,
}

impl PaintParams {
    /// The effects these parameters turn on, in chain order (decided without reading a file).
    pub(super) fn chain(&self) -> Vec<Step> {
        let on = [
            (Step::Chiaroscuro, self.chiaroscuro > 0.0),
            (Step::Silhouettes, self.silhouette_width > 0.0 && self.silhouette_strength > 0.0),
            (Step::Borders, self.border_width > 0.0 && self.border_strength > 0.0),
            (Step::Gradients, self.gradients > 0.0),
            (Step::Palette, self.palette_image.is_some() || palette::ramp(self.palette).is_some()),
            (Step::Quantise, self.colors > 0),
            (Step::PlaneLight, self.plane_light > 0.0),
            (Step::Brushwork, self.brushwork > 0.0),
            (Step::CanvasGrain, self.canvas_grain > 0.0),
        ];
        on.into_iter().filter(|(_, on)| *on).map(|(step, _)| step).collect()
    }

    /// Each enabled effect's parameters as text, in chain order (`Painter::keys`): what that
    /// effect reads of these parameters, with the canvas's background and transparency.
    pub fn keys(&self) -> Vec<String> {
        let p = self;
        let canvas = format!("{:?} {}", p.background, p.transparent);
        p.chain()
            .into_iter()
            .map(|step| {
                let own = match step {
                    Step::Chiaroscuro => format!("{} {}", p.chiaroscuro, p.seed),
                    Step::Silhouettes => format!("{} {} {}", p.silhouette_width, p.silhouette_strength, p.scale),
                    Step::Borders => format!(
                        "{} {} {} {:?} {} {} {}",
                        p.border_width,
                        p.border_strength,
                        p.scale,
                        p.border_style,
                        p.seed,
                        p.plane_light,
                        p.open_planes
                    ),
                    Step::Gradients => format!("{} {}", p.gradients, p.seed),
                    Step::Palette => format!("{:?} {:?} {}", p.palette_image, p.palette, p.seed),
                    Step::Quantise => format!("{}", p.colors),
                    Step::PlaneLight => format!("{} {}", p.plane_light, p.seed),
                    Step::Brushwork => {
                        format!("{} {} {} {} {}", p.brushwork, p.stroke_length, p.stroke_width, p.scale, p.seed)
                    }
                    Step::CanvasGrain => format!("{} {} {}", p.canvas_grain, p.scale, p.seed),
                };
                format!("{step:?} {own} {canvas}")
            })
            .collect()
    }

    /// Whether no effect is on: the paint stage is skipped and the render left as traced.
    pub fn is_off(&self) -> bool {
        self.chain().is_empty()
    }
}
