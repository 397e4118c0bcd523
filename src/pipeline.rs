//! The render pipeline of SPEC Fig. 4.1, each stage run only when the settings need it:
//! pre-render (one trace, every buffer) -> saliency -> facets -> spatial imprecision
//! (re-trace of moved facets) -> painterly effects -> image and passes.

use std::path::Path;
use std::time::{Duration, Instant};

use glam::{DVec2, Vec3};
use image::{ImageBuffer, Luma, RgbaImage};

use crate::accel::Accel;
use crate::camera::frame_camera;
use crate::error::Result;
use crate::facets::{self, FacetLayout, FacetMap};
use crate::frame::Frame;
use crate::imprecision::{self, AimContext, FacetAim};
use crate::output::encode;
use crate::paint::{Lighting, Painter};
use crate::progress::Progress;
use crate::render::{Tracer, splitmix64};
use crate::scene::{Scene, World};
use crate::settings::{Imprecision, Pass, Settings};
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

/// A 16-bit grey image (the `facet-ids` pass).
pub type Gray16 = ImageBuffer<Luma<u16>, Vec<u16>>;

pub struct Rendered {
    pub frame: Frame,
    pub image: RgbaImage,
    pub passes: Vec<(Pass, RgbaImage)>,
    /// Passes stored as 16-bit grey (facet ids), written with `output::write_png16`.
    pub passes16: Vec<(Pass, Gray16)>,
    /// The facet id of every pixel (a single facet when unfaceted); painterly effects read it.
    pub facets: Option<FacetMap>,
    /// Each facet's centres and re-aim, when the imprecision stage ran (else empty).
    pub aims: Vec<FacetAim>,
    pub timings: Timings,
    pub warnings: Vec<String>,
    /// One line saying which camera was used and where its focal centre is.
    pub camera: String,
}

/// Renders `settings` through the whole pipeline.
pub fn render(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<Rendered> {
    render_with(prep, settings, progress, &|_, _| {})
}

/// `render`, calling `after_saliency` on the frame once the pre-render and saliency stages are
/// done and before faceting: tests and evaluations use it to supply a known saliency map.
pub fn render_with(
    prep: &Prepared,
    settings: &Settings,
    progress: &Progress,
    after_saliency: &dyn Fn(&Prepared, &mut Frame),
) -> Result<Rendered> {
    settings.validate()?;
    let mut timings = Timings::default();
    let mut warnings = prep.scene.warnings.clone();
    let framed = frame_camera(settings, &prep.world)?;
    warnings.extend(framed.warnings.iter().cloned());
    let rig = LightRig::new(&prep.world, &framed.frame, settings.shadows, settings.exposure);
    let background = Vec3::from(settings.background);
    let tracer = Tracer { world: &prep.world, accel: &prep.accel, rig: Some(&rig), background, seed: settings.seed };
    let (width, height) = (settings.width, settings.height);

    // Built before tracing so a bad palette image fails fast; reusable across frames.
    let painter = timings.time("paint setup", || Painter::new(settings))?;

    let mut frame = Frame::new(width, height, settings.spp);
    progress.begin("pre-render", frame.pixel_count() as u64);
    timings.time("pre-render", || tracer.render(&mut frame, &|_, p| framed.camera.ray(p), None, progress));
    progress.finish();

    // Mesh saliency (SPEC "Mesh saliency") of the meshes the pre-render hit, and the saliency
    // map from the same samples (no second trace); only when a later stage reads it.
    if settings.needs_saliency() {
        progress.begin("saliency", 1);
        let sal = timings.time("saliency", || {
            crate::saliency::for_frame_with(prep, &frame, settings.saliency_cache.as_deref(), settings.saliency_method)
                .map(|sal| crate::saliency::saliency_map(&prep.world, &sal, &frame))
        })?;
        frame.saliency = Some(sal);
        progress.finish();
    }
    after_saliency(prep, &mut frame);

    // Faceting (SPEC "Faceting"): computed, or loaded so every frame of an animation shares it.
    let faceted = settings.faceted();
    let (layout, map) = if faceted {
        progress.begin("faceting", 1);
        timings.time("faceting", || -> Result<(FacetLayout, FacetMap)> {
            let layout = facets::layout_for(settings, &frame)?;
            let map = layout.rasterize(width, height);
            Ok((layout, map))
        })?
    } else {
        let layout = FacetLayout::single();
        let map = layout.rasterize(width, height);
        (layout, map)
    };
    if let (Some(path), Some(base)) = (&settings.facets, &layout.base) {
        let (a, b) = (width as f64 / height as f64, base.width as f64 / base.height as f64);
        if (a / b - 1.0).abs() > 0.01 {
            warnings.push(format!(
                "facet layout {} is {}x{}, stretched to this {width}x{height} image",
                path.display(),
                base.width,
                base.height
            ));
        }
    }

    // Saliency centres count pixels within `neighborhood` of a facet: bounded work, or an error.
    if faceted && settings.neighborhood > 0.0 && frame.saliency.is_some() {
        imprecision::check_neighbourhood(&map, settings.neighborhood * settings.pixel_scale())?;
    }

    // Spatial imprecision (SPEC "Spatial imprecision"): re-aim facets, re-trace only the pixels
    // of facets whose rays changed; at discontinuity 0 with converging facets nothing runs.
    let clip_radius = (prep.world.radius as f64).max(1e-9) * 1.001;
    let ctx = AimContext { camera: framed.camera.as_ref(), accel: &prep.accel, width, height, clip_radius };
    let mut aims = Vec::new();
    if faceted && imprecision::changes_rays(settings) {
        if settings.imprecision == Imprecision::Saliency && settings.discontinuity > 0.0 && frame.saliency.is_none() {
            warnings.push("no saliency map was computed: facets are not re-aimed (imprecision saliency)".into());
        }
        progress.begin("imprecision", 1);
        aims = timings.time("imprecision", || imprecision::aim_facets(&ctx, &map, frame.saliency.as_deref(), settings));
        let moved: Vec<u32> =
            (0..map.ids.len() as u32).filter(|&i| aims[map.ids[i as usize] as usize].moved()).collect();
        if !moved.is_empty() {
            let rays = |i: usize, p: DVec2| {
                aims[map.ids[i] as usize].apply(framed.camera.ray(p), ctx.pixel_pos(p), clip_radius)
            };
            progress.begin("re-trace", moved.len() as u64);
            timings.time("re-trace", || tracer.render(&mut frame, &rays, Some(&moved), progress));
            progress.finish();
        }
    }

    if !painter.is_empty() {
        // An unfaceted image has no facet borders or corners: no facet map for the painter.
        progress.begin("paint", 1);
        let view = crate::paint::chiaroscuro::ViewAxes {
            right: framed.frame.right.as_vec3(),
            up: framed.frame.up.as_vec3(),
            forward: framed.frame.forward.as_vec3(),
        };
        let lighting = Lighting { world: &prep.world, rig: &rig, view };
        timings.time("paint", || painter.apply(&mut frame, faceted.then_some(&map), Some(&lighting)))?;
    }

    let image = timings.time("encode", || encode(&frame, settings.background, settings.transparent));
    let mut passes = Vec::new();
    let mut passes16 = Vec::new();
    for &pass in &settings.passes {
        if let Some(img) = geometry_pass(&frame, pass) {
            passes.push((pass, img));
        }
        match pass {
            Pass::Facets => {
                let shown = if aims.is_empty() {
                    centres_only(&map, frame.saliency.as_deref(), settings)
                } else {
                    aims.clone()
                };
                passes.push((pass, facets_pass(&map, &shown, frame.saliency.as_deref(), settings.pixel_scale())));
            }
            Pass::FacetIds => passes16.push((pass, facet_ids_pass(&map))),
            // The final layout (Fig. 4.5 f); `cubist facets --pass segments` also shows each level.
            Pass::Segments => passes.push((pass, facets::segment::debug::map_image(&map))),
            _ => {}
        }
    }
    if let Some(path) = &settings.save_facets {
        facets::io::save(path, &layout, &map)?;
    }
    Ok(Rendered {
        frame,
        image,
        passes,
        passes16,
        facets: Some(map),
        aims,
        timings,
        warnings,
        camera: framed.describe(&prep.world),
    })
}

/// Facet and saliency centres without any re-aim, for the `facets` pass of a render whose
/// imprecision stage did not run.
fn centres_only(map: &FacetMap, saliency: Option<&[f32]>, settings: &Settings) -> Vec<FacetAim> {
    let fc = imprecision::facet_centres(map);
    let sc = match saliency {
        Some(s) => imprecision::saliency_centres(map, s, &fc, settings.neighborhood * settings.pixel_scale()),
        None => fc.clone(),
    };
    fc.iter()
        .zip(&sc)
        .map(|(&fc, &sc_raw)| FacetAim { fc, sc_raw, sc: fc, target: None, reaim: None, linear: None })
        .collect()
}

/// Facet ids as 16-bit grey values (layouts hold at most `facets::MAX_FACETS` facets).
fn facet_ids_pass(map: &FacetMap) -> Gray16 {
    ImageBuffer::from_fn(map.width, map.height, |x, y| Luma([map.ids[(y * map.width + x) as usize] as u16]))
}

/// The saliency map in grey tinted by facet colours (plain colours without saliency), facet borders dark, each facet centre
/// a yellow dot and saliency centre a red dot, with a red line from the facet centre to the
/// point the facet is aimed at (the thesis's Fig. 4.6 left).
pub fn facets_pass(map: &FacetMap, aims: &[FacetAim], saliency: Option<&[f32]>, scale: f64) -> RgbaImage {
    let (w, h) = (map.width, map.height);
    let mut img = RgbaImage::new(w, h);
    for (i, px) in img.pixels_mut().enumerate() {
        let id = map.ids[i];
        let c = splitmix64(id as u64 ^ 0x5eed);
        let base = [(c >> 8) as u8 as f32, (c >> 24) as u8 as f32, (c >> 40) as u8 as f32];
        // Saliency as grey (Fig. 4.6 left), tinted by the facet's colour.
        let tint = |c: f32| 60.0 + 0.7 * c;
        let rgb = match saliency {
            Some(s) => {
                let grey = 25.0 + 230.0 * s.get(i).copied().unwrap_or(0.0).clamp(0.0, 1.0);
                base.map(|c| 0.4 * tint(c) + 0.6 * grey)
            }
            None => base.map(tint),
        };
        let shade = if map.is_border(i) { 0.35 } else { 1.0 };
        px.0 = [(rgb[0] * shade) as u8, (rgb[1] * shade) as u8, (rgb[2] * shade) as u8, 255];
    }
    let r = (4.0 * scale).round().max(2.0);
    for a in aims {
        let Some(fc) = a.fc else { continue };
        if let Some(sc) = a.sc.filter(|sc| *sc != fc) {
            draw_line(&mut img, fc, sc, [230, 30, 30, 255]);
        }
        if let Some(sc) = a.sc_raw {
            draw_disc(&mut img, sc, r, [230, 30, 30, 255]);
        }
        draw_disc(&mut img, fc, r * 0.8, [255, 215, 0, 255]);
    }
    img
}

fn draw_disc(img: &mut RgbaImage, c: DVec2, r: f64, colour: [u8; 4]) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (x0, x1) = (((c.x - r).floor() as i64).max(0), ((c.x + r).ceil() as i64).min(w - 1));
    let (y0, y1) = (((c.y - r).floor() as i64).max(0), ((c.y + r).ceil() as i64).min(h - 1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            if (DVec2::new(x as f64 + 0.5, y as f64 + 0.5) - c).length() <= r {
                img.put_pixel(x as u32, y as u32, image::Rgba(colour));
            }
        }
    }
}

fn draw_line(img: &mut RgbaImage, a: DVec2, b: DVec2, colour: [u8; 4]) {
    let steps = (b - a).abs().max_element().ceil().max(1.0) as usize;
    for k in 0..=steps {
        let p = a + (b - a) * (k as f64 / steps as f64);
        let (x, y) = (p.x.floor() as i64, p.y.floor() as i64);
        if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
            img.put_pixel(x as u32, y as u32, image::Rgba(colour));
        }
    }
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
