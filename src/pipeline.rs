//! The render pipeline of SPEC Fig. 4.1, each stage run only when the settings need it:
//! pre-render (one trace, every buffer) -> saliency -> facets -> spatial imprecision
//! (re-trace of moved facets) -> painterly effects -> image and passes.

use std::path::Path;
use std::time::{Duration, Instant};

use glam::Vec3;
use image::RgbaImage;

use crate::accel::Accel;
use crate::camera::frame_camera;
use crate::error::Result;
use crate::frame::Frame;
use crate::output::encode;
use crate::progress::Progress;
use crate::render::{Tracer, splitmix64};
use crate::scene::{Scene, World};
use crate::settings::{Pass, Settings};
use crate::shading::LightRig;

/// A scene ready to trace: what stays the same between frames and views.
pub struct Prepared {
    pub scene: Scene,
    pub world: World,
    pub accel: Accel,
    /// Time spent flattening and building the BVH.
    pub build_time: Duration,
    /// Per-mesh saliency computed so far (by content), reused across views and frames.
    pub saliency: crate::saliency::Memo,
}

impl Prepared {
    pub fn new(scene: Scene) -> Prepared {
        let t = Instant::now();
        let world = World::new(&scene);
        let accel = Accel::new(&world);
        Prepared { scene, world, accel, build_time: t.elapsed(), saliency: Default::default() }
    }

    /// Loads `path`, or the built-in still life when None.
    pub fn load(path: Option<&Path>) -> Result<Prepared> {
        let scene = match path {
            Some(p) => Scene::load(p)?,
            None => Scene::default_scene(),
        };
        Ok(Prepared::new(scene))
    }
}

/// Named stage durations, in pipeline order.
#[derive(Clone, Debug, Default)]
pub struct Timings(pub Vec<(&'static str, Duration)>);

impl Timings {
    pub fn time<T>(&mut self, name: &'static str, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let r = f();
        self.0.push((name, t.elapsed()));
        r
    }
}

pub struct Rendered {
    pub frame: Frame,
    pub image: RgbaImage,
    pub passes: Vec<(Pass, RgbaImage)>,
    pub timings: Timings,
    pub warnings: Vec<String>,
    /// One line saying which camera was used and where its focal centre is.
    pub camera: String,
}

/// Renders `settings` through the whole pipeline.
pub fn render(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<Rendered> {
    settings.validate()?;
    let mut timings = Timings::default();
    let mut warnings = prep.scene.warnings.clone();
    let framed = frame_camera(settings, &prep.world)?;
    warnings.extend(framed.warnings.iter().cloned());
    let rig = LightRig::new(&prep.world, &framed.frame, settings.shadows, settings.exposure);
    let background = Vec3::from(settings.background);
    let tracer = Tracer { world: &prep.world, accel: &prep.accel, rig: Some(&rig), background, seed: settings.seed };

    let mut frame = Frame::new(settings.width, settings.height, settings.spp);
    progress.begin("pre-render", frame.pixel_count() as u64);
    timings.time("pre-render", || tracer.render(&mut frame, &|_, p| framed.camera.ray(p), None, progress));
    progress.finish();

    if settings.needs_saliency() {
        progress.begin("saliency", 1);
        let sal = timings.time("saliency", || {
            crate::saliency::for_frame_with(prep, &frame, settings.saliency_cache.as_deref(), settings.saliency_method)
                .map(|sal| crate::saliency::saliency_map(&prep.world, &sal, &frame))
        })?;
        frame.saliency = Some(sal);
        progress.finish();
    }

    let image = timings.time("encode", || encode(&frame, settings.background, settings.transparent));
    let mut passes = Vec::new();
    for &pass in &settings.passes {
        if let Some(img) = geometry_pass(&frame, pass) {
            passes.push((pass, img));
        }
    }
    Ok(Rendered { frame, image, passes, timings, warnings, camera: framed.describe(&prep.world) })
}

/// Passes read straight off the hit buffers (and the saliency map, when computed).
fn geometry_pass(frame: &Frame, pass: Pass) -> Option<RgbaImage> {
    let mut img = RgbaImage::new(frame.width, frame.height);
    match pass {
        Pass::Objects => {
            for (px, h) in img.pixels_mut().zip(&frame.hits) {
                px.0 = if h.is_hit() {
                    let c = splitmix64(h.object as u64 + 1);
                    [(c >> 16) as u8 | 0x30, (c >> 24) as u8 | 0x30, (c >> 32) as u8 | 0x30, 255]
                } else {
                    [0, 0, 0, 255]
                };
            }
        }
        Pass::Normals => {
            for (px, h) in img.pixels_mut().zip(&frame.hits) {
                let n = h.normal * 0.5 + Vec3::splat(0.5);
                px.0 = if h.is_hit() {
                    [(n.x * 255.0) as u8, (n.y * 255.0) as u8, (n.z * 255.0) as u8, 255]
                } else {
                    [0, 0, 0, 255]
                };
            }
        }
        Pass::Depth => {
            let (lo, hi) = frame
                .hits
                .iter()
                .filter(|h| h.is_hit())
                .fold((f32::INFINITY, 0.0f32), |(lo, hi), h| (lo.min(h.t), hi.max(h.t)));
            for (px, h) in img.pixels_mut().zip(&frame.hits) {
                let g = if h.is_hit() && hi > lo {
                    255.0 * (1.0 - (h.t - lo) / (hi - lo)) * 0.9 + 25.0
                } else if h.is_hit() {
                    255.0
                } else {
                    0.0
                };
                px.0 = [g as u8, g as u8, g as u8, 255];
            }
        }
        Pass::Saliency => {
            let map = frame.saliency.as_ref()?;
            return Some(crate::saliency::saliency_image(map, frame.width, frame.height));
        }
        _ => return None,
    }
    Some(img)
}
