//! The pre-render: the camera framed for the scene, then one trace of
//! the whole image into every buffer the later stages read. Rendering, facet inspection, the
//! saliency map and face counting all start here.

use glam::Vec3;

use crate::error::Result;
use crate::film::Film;
use crate::framing::{Framed, FramingParams, frame_camera};
use crate::pipeline::cache::Gen;
use crate::pipeline::{Prepared, Stage, Timings};
use crate::progress::Progress;
use crate::shading::LightRig;
use crate::trace::{TraceParams, Tracer};

/// What the pre-render reads: the scene (its generation), the framing and the trace.
#[derive(PartialEq)]
pub struct Key {
    pub scene: Gen,
    pub framing: FramingParams,
    pub trace: TraceParams,
}

/// Whether the pre-render shades its samples or only records their hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shading {
    /// Colour from the scene's lights (a render).
    Lit,
    /// Hits only, colour black (the saliency map, face counting): no light rig, no shadow rays.
    HitsOnly,
    /// A render whose stages before the re-trace read no colour: one sample per pixel traced
    /// for its hits now, the lights kept for `shade_stage`, which shades only the pixels the
    /// re-trace does not trace again (bit for bit as `Lit` shades them). Until then the
    /// film's colour is black (alpha, the coverage, is right).
    Deferred,
}

/// The pre-render's output. Depends only on the scene, `FramingParams`, `TraceParams` and the
/// shading.
pub struct PreRender {
    pub film: Film,
    pub view: View,
    /// The scene's and the framing's warnings.
    pub warnings: Vec<String>,
    /// Traced with `Shading::Deferred`: colour still to shade (`shade_stage`).
    pub unshaded: bool,
}

/// The camera the pre-render was traced through and its lights, kept for the re-trace and
/// chiaroscuro.
pub struct View {
    pub framed: Framed,
    /// None with `Shading::HitsOnly`.
    pub rig: Option<LightRig>,
}

impl View {
    /// A tracer of the same scene, lights, background and seed as the pre-render (the
    /// re-trace of moved facets must match it everywhere else).
    pub fn tracer<'a>(&'a self, prep: &'a Prepared, trace: &TraceParams) -> Tracer<'a> {
        tracer(prep, self.rig.as_ref(), trace)
    }

    /// One line saying which camera was used and where its focal centre is.
    pub fn describe_camera(&self, prep: &Prepared) -> String {
        self.framed.describe(&prep.world)
    }
}

/// The tracer of `prep` with `rig` (None: hits only, on a black background).
fn tracer<'a>(prep: &'a Prepared, rig: Option<&'a LightRig>, trace: &TraceParams) -> Tracer<'a> {
    let background = if rig.is_some() { Vec3::from(trace.background) } else { Vec3::ZERO };
    Tracer { world: &prep.world, accel: &prep.accel, rig, background, seed: trace.seed }
}

/// Frames the camera for the scene and traces every pixel (progress stage `pre-render`): one
/// sample at its centre when lit, `spp` for hits only.
pub fn prerender(
    prep: &Prepared,
    framing: &FramingParams,
    trace: &TraceParams,
    shading: Shading,
    progress: &Progress,
    timings: &mut Timings,
) -> Result<PreRender> {
    let mut warnings = prep.scene.warnings.clone();
    let framed = timings.time("framing", || frame_camera(framing, &prep.world, &prep.accel))?;
    warnings.extend(framed.warnings.iter().cloned());
    let rig = match shading {
        Shading::Lit | Shading::Deferred => {
            Some(LightRig::new(&prep.world, &framed.frame, trace.shadows, trace.exposure))
        }
        Shading::HitsOnly => None,
    };
    // Bounded work: every light is evaluated at every sample; hours of work are refused up front.
    if let Some(rig) = &rig {
        let work = rig.lights.len() as u64 * trace.width as u64 * trace.height as u64 * trace.spp as u64;
        if work > crate::util::limits::MAX_LIGHT_SAMPLES {
            return Err(crate::error::Error::scene(
                &prep.scene.source,
                format!(
                    "{} lights x {} samples is {:.2e} light evaluations, more than the limit of {:.0e}: \
                     fewer lights, pixels or samples per pixel",
                    rig.lights.len(),
                    trace.width as u64 * trace.height as u64 * trace.spp as u64,
                    work as f64,
                    crate::util::limits::MAX_LIGHT_SAMPLES as f64
                ),
            ));
        }
    }
    // A render's pre-render traces each pixel's centre once: faceting, saliency and the aims
    // need no more, and the anti-aliasing stage adds samples where the picture needs them.
    // The hits-only products (the saliency map, face counts) keep `spp` samples per pixel.
    let spp = match shading {
        Shading::Lit | Shading::Deferred => 1,
        Shading::HitsOnly => trace.spp,
    };
    // Every pixel is traced below, so its buffers need no fill first (a cancelled trace is
    // refused before its film is seen).
    let mut film = Film::to_be_traced(trace.width, trace.height, spp);
    progress.begin(Stage::PreRender.name(), film.pixel_count() as u64);
    // Deferred: traced as hits only (no lights), shaded later with the rig kept here.
    let unshaded = shading == Shading::Deferred;
    let tracer = tracer(prep, rig.as_ref().filter(|_| !unshaded), trace);
    let camera = framed.camera.as_ref();
    timings.time(Stage::PreRender.name(), || {
        let rays = camera.centre_rays(trace.width, trace.height);
        tracer.render(&mut film, &*rays, None, None, progress)
    });
    progress.finish();
    progress.check()?;
    Ok(PreRender { film, view: View { framed, rig }, warnings, unshaded })
}
