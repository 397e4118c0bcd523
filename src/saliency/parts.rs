//! Part saliency: the small separate parts of the subject (an eye, a beak, a valve cap), which
//! mesh saliency cannot see: it compares each vertex with its own mesh's surroundings, so a
//! part modelled as a mesh of its own (a sphere for an eye) has no variation and scores 0.
//!
//! A part's saliency follows its size against the subject's (bounding-box diagonals in render
//! space, so it holds while the part is hidden or the camera moves): 1 up to `SMALL` of the
//! subject's, 0 from `LARGE`, log-linear between. The scene's settings (a floor, a room around
//! the camera) are not part of the subject and score 0.

use crate::scene::World;

/// Parts at most this share of the subject's size are fully salient.
pub const SMALL: f64 = 0.08;
/// Parts at least this share of the subject's size are not salient.
pub const LARGE: f64 = 0.3;

/// Each object's part saliency in [0, 1], by index into `World::objects`.
pub fn part_saliency(world: &World) -> Vec<f32> {
    let diag = |lo: glam::Vec3, hi: glam::Vec3| (hi - lo).length() as f64;
    let mut subject: Option<(glam::Vec3, glam::Vec3)> = None;
    for (o, ob) in world.objects.iter().enumerate() {
        if let (false, Some((lo, hi, _))) = (world.is_setting(o), ob.bounds) {
            subject = Some(subject.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
    }
    let Some((lo, hi)) = subject else { return vec![0.0; world.objects.len()] };
    let size = diag(lo, hi);
    world
        .objects
        .iter()
        .enumerate()
        .map(|(o, ob)| match ob.bounds {
            Some((lo, hi, _)) if !world.is_setting(o) && size > 0.0 => {
                let share = (diag(lo, hi) / size).max(1e-12);
                ((LARGE / share).ln() / (LARGE / SMALL).ln()).clamp(0.0, 1.0) as f32
            }
            _ => 0.0,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use glam::{DMat4, DVec3, Vec3};

    use super::*;
    use crate::pipeline::Prepared;
    use crate::scene::default::ellipsoid;
    use crate::scene::{Material, Object, Scene};

    /// A body of radius 1 with an eye of radius `eye` beside it.
    fn body_and_eye(eye: f64) -> Prepared {
        let mut s = Scene::default();
        s.materials.push(Material::default());
        s.meshes.push(ellipsoid("ball", Vec3::ONE, 12, 24, 0));
        let place = |c: DVec3, r: f64| DMat4::from_translation(c) * DMat4::from_scale(DVec3::splat(r));
        s.objects.push(Object { name: "body".into(), mesh: 0, transform: place(DVec3::ZERO, 1.0) });
        s.objects.push(Object { name: "eye".into(), mesh: 0, transform: place(DVec3::new(0.0, 0.5, 1.0), eye) });
        Prepared::new(s)
    }

    #[test]
    fn a_small_part_is_salient_and_the_body_is_not() {
        let p = body_and_eye(0.05);
        let s = part_saliency(&p.world);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0], 0.0, "the body is most of the subject");
        assert_eq!(s[1], 1.0, "an eye a few hundredths of the subject's size");
    }

    #[test]
    fn saliency_falls_with_the_part_size() {
        let s: Vec<f32> = [0.1, 0.2, 0.3, 0.5].iter().map(|&r| part_saliency(&body_and_eye(r).world)[1]).collect();
        assert!(s.windows(2).all(|w| w[0] >= w[1]), "{s:?}");
        assert!(s[0] > 0.0 && s[0] < 1.0, "{s:?}");
        assert_eq!(s[3], 0.0, "{s:?}");
    }
}
