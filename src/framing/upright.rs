//! The renderer's own view of a subject standing along the view axis (`Upright`): a z-up model
//! in a y-up glTF file would otherwise be seen from above its head, its length foreshortened
//! into a blob; it is seen from the front instead, its long axis up the picture.

use glam::DVec3;

/// How many times its longest other extent the subject's extent along Z must be before the
/// front view (down -Z) is taken to look along its length.
pub const LONG_RATIO: f64 = 1.6;

/// A view frame for the renderer's own view: the direction it looks and the picture's up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Upright {
    pub forward: DVec3,
    pub up: DVec3,
}

impl Upright {
    /// The view of `points` (render space, axes as the scene's) when their extent along Z is at
    /// least `LONG_RATIO` times both others and X is broader than Y: a z-up model standing, its
    /// front facing -Y. It is seen as Blender's front view shows it: along +Y, Z up the
    /// picture. A subject long along Z but taller than wide (an animal facing the camera, y-up)
    /// keeps the front view. None otherwise, or without points.
    pub fn of(points: &[DVec3]) -> Option<Upright> {
        let (lo, hi) =
            points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let e = hi - lo;
        if !e.is_finite() || e.z < LONG_RATIO * e.x.max(e.y) || e.x <= e.y {
            return None;
        }
        Some(Upright { forward: DVec3::Y, up: DVec3::Z })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxed(e: DVec3) -> Vec<DVec3> {
        (0..8)
            .map(|i| DVec3::new(e.x * (i & 1) as f64, e.y * ((i >> 1) & 1) as f64, e.z * ((i >> 2) & 1) as f64))
            .collect()
    }

    #[test]
    fn a_figure_standing_along_z_is_seen_from_the_front_upright() {
        let v = Upright::of(&boxed(DVec3::new(0.5, 0.3, 1.8))).expect("standing along Z");
        assert_eq!((v.forward, v.up), (DVec3::Y, DVec3::Z));
    }

    #[test]
    fn y_up_and_compact_subjects_keep_the_front_view() {
        assert_eq!(Upright::of(&boxed(DVec3::new(0.5, 1.8, 0.3))), None, "a y-up figure");
        assert_eq!(Upright::of(&boxed(DVec3::new(0.3, 0.6, 1.8))), None, "a y-up animal facing the camera");
        assert_eq!(Upright::of(&boxed(DVec3::new(1.0, 1.0, 1.5))), None, "under the ratio");
        assert_eq!(Upright::of(&[]), None);
        assert_eq!(Upright::of(&[DVec3::new(f64::NAN, 0.0, 0.0)]), None);
    }
}
