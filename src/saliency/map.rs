//! The saliency map (SPEC "Mesh saliency", thesis 4.3.2 step 1): per pixel, the hit point's
//! saliency interpolated from its triangle's vertices by the barycentrics, averaged over the
//! pixel's samples, 0 for background. Read off the pre-render's sample buffer: no second trace.

use image::RgbaImage;
use rayon::prelude::*;

use super::{MeshSaliency, for_frame_with};
use crate::camera::frame_camera;
use crate::error::Result;
use crate::frame::Frame;
use crate::pipeline::{Prepared, Timings};
use crate::progress::Progress;
use crate::render::Tracer;
use crate::scene::World;
use crate::settings::Settings;

/// Per-pixel saliency in [0, 1]: the mean over ALL samples of the pixel, misses counting 0.
pub fn saliency_map(world: &World, sal: &MeshSaliency, frame: &Frame) -> Vec<f32> {
    let spp = frame.spp.max(1) as usize;
    frame
        .samples
        .par_chunks(spp)
        .map(|samples| {
            let mut sum = 0.0f32;
            for s in samples.iter().filter(|s| s.is_hit()) {
                let (o, local) = world.local_triangle(s.tri);
                let mesh = world.objects[o as usize].mesh;
                if let Some(Some(c)) = sal.corners.get(mesh)
                    && let Some(c) = c.get(local as usize)
                {
                    sum += (1.0 - s.u - s.v) * c[0] + s.u * c[1] + s.v * c[2];
                }
            }
            (sum / spp as f32).clamp(0.0, 1.0)
        })
        .collect()
}

/// The map as an opaque grey image (value v -> grey round(255 v), linear: it is data).
pub fn saliency_image(map: &[f32], width: u32, height: u32) -> RgbaImage {
    let mut img = RgbaImage::new(width, height);
    for (px, v) in img.pixels_mut().zip(map) {
        let g = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        px.0 = [g, g, g, 255];
    }
    img
}

/// What `cubist saliency` produces.
pub struct SaliencyRender {
    pub frame: Frame,
    pub mesh: MeshSaliency,
    pub image: RgbaImage,
    pub timings: Timings,
    pub warnings: Vec<String>,
    /// One line saying which camera was used.
    pub camera: String,
}

/// Traces the pre-render's hits only (no shading: the map needs none) through the settings'
/// camera and returns the saliency map.
pub fn render_map(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<SaliencyRender> {
    settings.validate()?;
    let mut timings = Timings::default();
    let mut warnings = prep.scene.warnings.clone();
    let framed = frame_camera(settings, &prep.world, &prep.accel)?;
    warnings.extend(framed.warnings.iter().cloned());
    let tracer =
        Tracer { world: &prep.world, accel: &prep.accel, rig: None, background: glam::Vec3::ZERO, seed: settings.seed };
    let mut frame = Frame::new(settings.width, settings.height, settings.spp);
    progress.begin("pre-render", frame.pixel_count() as u64);
    timings.time("pre-render", || tracer.render(&mut frame, &|_, p| framed.camera.ray(p), None, progress));
    progress.finish();
    progress.begin("saliency", 1);
    let mesh = timings.time("saliency", || {
        for_frame_with(prep, &frame, settings.saliency_cache.as_deref(), settings.saliency_method)
    })?;
    let map = saliency_map(&prep.world, &mesh, &frame);
    progress.finish();
    let image = saliency_image(&map, frame.width, frame.height);
    frame.saliency = Some(map);
    Ok(SaliencyRender { frame, mesh, image, timings, warnings, camera: framed.describe(&prep.world) })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::Vec3;

    use super::*;
    use crate::frame::SampleHit;
    use crate::scene::{Mesh, Object, Scene};

    fn two_triangle_scene() -> Scene {
        let mesh = Mesh {
            name: "quad".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            normals: vec![Vec3::Z; 4],
            uvs: None,
            colors: None,
            triangles: vec![[0, 1, 2], [1, 3, 2]],
            material: None,
        };
        Scene {
            meshes: vec![mesh],
            objects: vec![Object { name: "o".into(), mesh: 0, transform: glam::DMat4::IDENTITY }],
            ..Default::default()
        }
    }

    #[test]
    fn interpolates_by_barycentrics_and_averages_all_samples() {
        let scene = two_triangle_scene();
        let world = World::new(&scene);
        let sal = MeshSaliency::new(&scene, vec![Some(Arc::new(vec![0.0, 1.0, 0.5, 0.25]))]);
        assert_eq!(sal.corners[0].as_ref().unwrap()[1], [1.0, 0.25, 0.5]);
        let mut frame = Frame::new(2, 1, 2);
        // Pixel 0: one hit at (u, v) = (0.5, 0.25) on triangle 0 -> 0.5*1 + 0.25*0.5 = 0.625,
        // one miss -> mean 0.3125. Pixel 1: triangle 1 at its first corner twice -> 1.0.
        frame.samples = vec![
            SampleHit { tri: 0, u: 0.5, v: 0.25 },
            SampleHit::MISS,
            SampleHit { tri: 1, u: 0.0, v: 0.0 },
            SampleHit { tri: 1, u: 0.0, v: 0.0 },
        ];
        let map = saliency_map(&world, &sal, &frame);
        assert!((map[0] - 0.3125).abs() < 1e-6, "{map:?}");
        assert!((map[1] - 1.0).abs() < 1e-6);
        let img = saliency_image(&map, 2, 1);
        assert_eq!(img.get_pixel(0, 0).0, [80, 80, 80, 255]);
        assert_eq!(img.get_pixel(1, 0).0, [255, 255, 255, 255]);
    }

    #[test]
    fn meshes_not_computed_read_as_zero() {
        let scene = two_triangle_scene();
        let world = World::new(&scene);
        let sal = MeshSaliency::new(&scene, vec![None]);
        let mut frame = Frame::new(1, 1, 1);
        frame.samples = vec![SampleHit { tri: 0, u: 0.2, v: 0.2 }];
        assert_eq!(saliency_map(&world, &sal, &frame), vec![0.0]);
    }
}
