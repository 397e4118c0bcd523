//! What the framing frames: the scene without its backdrops (`scene::backdrop`: a floor or a
//! wall much larger than the rest; ART.md "The subject fills the canvas"). Framed with its
//! floor, a scene of objects on a 20 m plane showed them a few pixels tall on a kite of floor.
//! The backdrop is still rendered, shaded and faceted like anything else; it only does not set
//! the extent, the centre and the radius the cameras are composed around.

use glam::DVec3;

use crate::scene::World;

/// The subject's sample points, centre and radius (render space).
pub struct Subject {
    /// The centre of the subject's bounding box: the origin (the scene's centre) when there is
    /// no backdrop.
    pub centre: DVec3,
    /// The subject's bounding radius about `centre`: the scene's when there is no backdrop.
    pub radius: f64,
    full: Vec<DVec3>,
    coarse: Vec<DVec3>,
}

impl Subject {
    /// The subject of `world`, with about `full` and `coarse` sample points (every n-th corner
    /// of the subject's triangles; with no backdrop, exactly the corners a sample of the whole
    /// scene takes).
    pub fn new(world: &World, full: usize, coarse: usize) -> Subject {
        let keep: Vec<usize> =
            (0..world.objects.len()).filter(|&o| !world.backdrops.iter().any(|b| b.object == o)).collect();
        let (centre, radius) = if world.backdrops.is_empty() {
            (DVec3::ZERO, (world.radius as f64).max(1e-9))
        } else {
            let (lo, hi) = keep
                .iter()
                .filter_map(|&o| world.objects[o].bounds)
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), b| {
                    (lo.min(b.0.as_dvec3()), hi.max(b.1.as_dvec3()))
                });
            ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-9))
        };
        Subject { full: sample(world, &keep, full), coarse: sample(world, &keep, coarse), centre, radius }
    }

    /// The sample points: `coarse` or full.
    pub fn points(&self, coarse: bool) -> &[DVec3] {
        if coarse { &self.coarse } else { &self.full }
    }
}

/// Corners of the `objects`' triangles (a bounded sample, every n-th in triangle order) in
/// render space; non-finite ones (never hit) skipped.
fn sample(world: &World, objects: &[usize], samples: usize) -> Vec<DVec3> {
    let ranges: Vec<(usize, usize)> = objects
        .iter()
        .map(|&o| &world.objects[o])
        .map(|o| (o.first_triangle as usize * 3, o.triangle_count as usize * 3))
        .collect();
    let n: usize = ranges.iter().map(|r| r.1).sum();
    let step = n.div_ceil(samples).max(1);
    let mut out = Vec::with_capacity(n.div_ceil(step));
    // The k-th corner of the objects' corners laid end to end, every `step`-th.
    let (mut k, mut before) = (0, 0);
    for &(first, count) in &ranges {
        while k < before + count {
            let p = world.corner(first + k - before);
            if p.is_finite() {
                out.push(p.as_dvec3());
            }
            k += step;
        }
        before += count;
    }
    out
}
