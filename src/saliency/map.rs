//! The saliency map (thesis 4.3.2 step 1): per pixel, the hit point's
//! saliency interpolated from its triangle's vertices by the barycentrics, averaged over the
//! pixel's samples, 0 for background. Read off the pre-render's sample buffer: no second trace.

use image::RgbaImage;
use rayon::prelude::*;

use super::MeshSaliency;
use crate::film::Film;
use crate::scene::World;

/// The saliency map: `pixel_saliency`, raised to `params.parts` times each pixel's part
/// saliency (`parts`) where that is higher.
pub fn saliency_map(world: &World, sal: &MeshSaliency, film: &Film, params: &super::SaliencyParams) -> Vec<f32> {
    let part = params.reads_parts().then(|| super::parts::part_saliency(world));
    map_of(world, sal, film, part.as_deref().map(|p| (p, params.parts)))
}

/// Per-pixel saliency in [0, 1]: the mean over ALL samples of the pixel, misses counting 0.
pub fn pixel_saliency(world: &World, sal: &MeshSaliency, film: &Film) -> Vec<f32> {
    map_of(world, sal, film, None)
}

/// `pixel_saliency`, and with `part` (each object's part saliency, its weight) the higher of
/// that and the weighted mean of the samples' part saliency, in one pass over the samples.
fn map_of(world: &World, sal: &MeshSaliency, film: &Film, part: Option<(&[f32], f32)>) -> Vec<f32> {
    let spp = film.spp.max(1) as usize;
    film.samples
        .par_chunks(spp)
        .map(|samples| {
            let (mut sum, mut parts) = (0.0f32, 0.0f32);
            for s in samples.iter().filter(|s| s.is_hit()) {
                let (o, local) = world.local_triangle(s.tri);
                let mesh = world.objects[o as usize].mesh;
                if let Some(Some(c)) = sal.corners.get(mesh)
                    && let Some(c) = c.get(local as usize)
                {
                    sum += (1.0 - s.u - s.v) * c[0] + s.u * c[1] + s.v * c[2];
                }
                if let Some((p, _)) = part {
                    parts += p.get(o as usize).copied().unwrap_or(0.0);
                }
            }
            let mesh = (sum / spp as f32).clamp(0.0, 1.0);
            match part {
                Some((_, weight)) => mesh.max((weight * parts / spp as f32).clamp(0.0, 1.0)),
                None => mesh,
            }
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

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::Vec3;

    use super::*;
    use crate::film::SampleHit;
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
        let mut film = Film::new(2, 1, 2);
        // Pixel 0: one hit at (u, v) = (0.5, 0.25) on triangle 0 -> 0.5*1 + 0.25*0.5 = 0.625,
        // one miss -> mean 0.3125. Pixel 1: triangle 1 at its first corner twice -> 1.0.
        film.samples = vec![
            SampleHit { tri: 0, u: 0.5, v: 0.25 },
            SampleHit::MISS,
            SampleHit { tri: 1, u: 0.0, v: 0.0 },
            SampleHit { tri: 1, u: 0.0, v: 0.0 },
        ];
        let map = pixel_saliency(&world, &sal, &film);
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
        let mut film = Film::new(1, 1, 1);
        film.samples = vec![SampleHit { tri: 0, u: 0.2, v: 0.2 }];
        assert_eq!(pixel_saliency(&world, &sal, &film), vec![0.0]);
    }
}
