//! The set-up the imprecision tests share (review D2): the built-in still life's pre-render
//! at 160 x 120 under the default settings, cut into a grid of 48 facets of 20 x 20 pixels,
//! and facets re-aimed at random points (no saliency map needed). Named `tests.rs`: the
//! architecture check (tests/architecture.rs) skips test code, which may reach across modules.

use super::{AimContext, AimMode, AimParams};
use crate::facets::FacetMap;
use crate::pipeline::{PreRender, Prepared, Shading, StageParams, Timings, prerender};
use crate::progress::Progress;
use crate::settings::Settings;

/// Image size of the grid's pre-render.
pub const WIDTH: u32 = 160;
pub const HEIGHT: u32 = 120;

/// The still life, its pre-render and the facet grid.
pub struct Grid {
    pub prep: Prepared,
    pub params: StageParams,
    pub pre: PreRender,
    pub map: FacetMap,
    /// The cameras' clip radius (as the pipeline's aim context sets it).
    pub clip_radius: f64,
}

impl Grid {
    /// The still life pre-rendered with `shading`, and the grid of 48 facets.
    pub fn new(shading: Shading) -> Grid {
        let prep = Prepared::load(None).unwrap();
        let s = Settings { width: WIDTH, height: HEIGHT, ..Settings::default() };
        let params = StageParams::new(&s);
        let pre =
            prerender(&prep, &params.framing, &params.trace, shading, &Progress::silent(), &mut Timings::default())
                .unwrap();
        let ids = (0..WIDTH * HEIGHT).map(|i| (i % WIDTH) / 20 + 8 * ((i / WIDTH) / 20)).collect();
        let map = FacetMap { width: WIDTH, height: HEIGHT, ids, facet_count: 48 };
        let clip_radius = prep.world.radius as f64 * 1.001;
        Grid { prep, params, pre, map, clip_radius }
    }

    /// The pre-render's camera and the scene, to re-aim facets.
    pub fn ctx(&self) -> AimContext<'_> {
        AimContext {
            camera: self.pre.view.framed.camera.as_ref(),
            accel: &self.prep.accel,
            width: WIDTH,
            height: HEIGHT,
            clip_radius: self.clip_radius,
            up: self.pre.view.framed.frame.up,
        }
    }

    /// Every facet re-aimed at a random point within `discontinuity` pixels, none held on the
    /// backdrop.
    pub fn random_aims(&self, discontinuity: f64) -> AimParams {
        AimParams { mode: AimMode::Random, discontinuity, scale: 1.0, min_coverage: 0.0, ..self.params.aim.clone() }
    }
}
