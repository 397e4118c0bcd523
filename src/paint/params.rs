//! The painterly effects' parameters (`PaintParams`): each effect's own struct (in its file),
//! in the chain's fixed order (see the module doc of `paint` for why this order).

use super::borders::BorderParams;
use super::brushwork::BrushworkParams;
use super::canvas::CanvasGrainParams;
use super::chiaroscuro::ChiaroscuroParams;
use super::contours::ContourParams;
use super::effect::EffectParams;
use super::gradients::GradientParams;
use super::palette::PaletteParams;
use super::passage::PassageParams;
use super::plane_light::PlaneLightParams;
use super::quantise::QuantiseParams;
use super::silhouettes::SilhouetteParams;
use super::values::ValueParams;

/// Declares `PaintParams` with one field per effect and `PaintParams::effects`, which lists
/// them in the order written: the chain's one list.
macro_rules! chain {
    ($($effect:ident: $params:ty,)*) => {
        /// What the painterly effects need besides the render: each effect's parameters (see
        /// its struct; distances are pixels at 1000 px, strengths and fractions in [0, 1]),
        /// and what the canvas and the context hold for all of them.
        #[derive(Clone, Debug, PartialEq)]
        pub struct PaintParams {
            $(pub $effect: $params,)*
            /// The facets include planes left whole across the subject's outline (the planes
            /// faceting's passage): such a plane is one region for the effects
            /// (`PaintContext::regions`).
            pub open_planes: bool,
            /// The render's background, linear RGB, and whether the output is transparent.
            pub background: [f32; 3],
            pub transparent: bool,
        }

        impl PaintParams {
            /// Every effect's parameters, on or off, in chain order.
            pub fn effects(&self) -> Vec<&dyn EffectParams> {
                vec![$(&self.$effect),*]
            }
        }
    };
}

// The chain, in its fixed order (the module doc of `paint` says why): a new effect is one
// line here.
chain! {
    chiaroscuro: ChiaroscuroParams,
    silhouettes: SilhouetteParams,
    borders: BorderParams,
    gradients: GradientParams,
    palette: PaletteParams,
    quantise: QuantiseParams,
    brushwork: BrushworkParams,
    plane_light: PlaneLightParams,
    contours: ContourParams,
    passage: PassageParams,
    values: ValueParams,
    canvas_grain: CanvasGrainParams,
}

impl PaintParams {
    /// The effects these parameters turn on, in chain order.
    pub fn chain(&self) -> Vec<&dyn EffectParams> {
        self.effects().into_iter().filter(|e| e.is_on()).collect()
    }

    /// Whether no effect is on: the paint stage is skipped and the render left as traced.
    pub fn is_off(&self) -> bool {
        self.chain().is_empty()
    }
}
