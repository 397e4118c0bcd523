//! Where strokes go: stroke seeds, the interface between whatever places strokes and the
//! brushwork that paints them (`paint::brushwork`). A seed is a screen position in this frame,
//! a stable id (everything random about its stroke, its length, turn, value jitter, bristles
//! and compositing order, comes from the id, so the same seed paints the same stroke in every
//! frame), the plane it belongs to (None: the facet under its position), an opacity (seeds
//! fade in and out rather than appear or vanish) and whether it is carried with a surface.
//!
//! Two sources:
//! - `grid_seeds`: one seed per cell of a seeded jittered grid over the picture, fixed on the
//!   canvas (a still's strokes, and the background's in animation frames);
//! - `surface::SurfaceSeeds`: seeds anchored to the geometry (triangle and barycentrics), so
//!   they move with the surfaces from frame to frame (Meier 1996's particles), each with
//!   where it was on the key frame's picture, where its hatching is laid (`Laid`).

pub mod surface;

use glam::{Mat2, Vec2};

use crate::util::rng::{splitmix64, unit_f64};

/// One stroke's anchor this frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeSeed {
    /// Screen position, pixels (x right, y down, the top-left corner at 0).
    pub pos: Vec2,
    /// Stable id: the stroke's randomness.
    pub id: u64,
    /// The facet (plane) the stroke belongs to; None: the facet under `pos`.
    pub plane: Option<u32>,
    /// In [0, 1]: fading in or out.
    pub opacity: f32,
    /// Whether the seed moves with a surface from frame to frame (by fractions of a pixel: its
    /// stroke reads the picture between pixels). It is hatched on the picture its `laid` names,
    /// else keeps its place (on this frame's rows it would jump from row to row). A seed fixed
    /// on the canvas is hatched like a still's.
    pub carried: bool,
    /// A carried seed: where its point was on the picture its hatching is laid on (`Laid`),
    /// so it is hatched there and its rows move with the surface.
    pub laid: Option<Laid>,
    /// A seed fixed on the canvas under the subject: its stroke paints the ground of its
    /// `plane` alone (where the ground shows around the subject), as if the subject were not
    /// there, so the still ground's strokes stay whatever the subject does in front of them.
    pub ground: bool,
}

/// Where a carried seed's surface point was on the picture the hatching of a sequence is laid
/// on (the key frame's: pixels, x right, y down), and the surface's local map from that
/// picture to this frame's (the triangle's, affine): a stroke placed on a row there is placed
/// at `pos + to_frame * (row place - at)` here, so rows move and turn with the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Laid {
    pub at: Vec2,
    pub to_frame: Mat2,
}

/// The seeds of one layer of strokes (`layer` 0 the coarse one, 1 the fine one) whose strokes
/// sit `cell` pixels apart on average, on a `width x height` picture, in a fixed order (the
/// brushwork's composite order comes from the ids, not from this order).
/// `seed` is the brushwork's own (salted): a source keys its ids on it.
pub trait SeedSource: Sync {
    fn seeds(&self, seed: u64, layer: u64, cell: f32, width: usize, height: usize) -> Vec<StrokeSeed>;
}

/// The jittered grid of a still (`grid_seeds`).
pub struct Grid;

impl SeedSource for Grid {
    fn seeds(&self, seed: u64, layer: u64, cell: f32, width: usize, height: usize) -> Vec<StrokeSeed> {
        grid_seeds(seed, layer, cell, width, height, |_| true)
    }
}

/// One seed per cell of a `cell`-pixel grid, at a seeded point of the cell (cells whose point
/// falls outside the picture, or where `keep(pos)` is false, have none), in scan order of the
/// cells; a cell's id depends on the seed, the layer and the cell alone.
pub fn grid_seeds(
    seed: u64,
    layer: u64,
    cell: f32,
    width: usize,
    height: usize,
    keep: impl Fn(Vec2) -> bool,
) -> Vec<StrokeSeed> {
    let (nx, ny) = ((width as f32 / cell).ceil() as usize, (height as f32 / cell).ceil() as usize);
    let layer_seed = splitmix64(seed ^ layer);
    let mut out = Vec::new();
    for cy in 0..ny {
        for cx in 0..nx {
            let id = splitmix64(layer_seed ^ splitmix64((cy * nx + cx) as u64));
            let r = |k: u64| unit_f64(splitmix64(id ^ k)) as f32;
            let pos = Vec2::new((cx as f32 + r(1)) * cell, (cy as f32 + r(2)) * cell);
            if (pos.x as usize) < width && (pos.y as usize) < height && keep(pos) {
                out.push(StrokeSeed { pos, id, plane: None, opacity: 1.0, carried: false, laid: None, ground: false });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_seeds_are_one_per_cell_and_repeat() {
        let a = grid_seeds(7, 0, 10.0, 100, 50, |_| true);
        assert_eq!(a.len(), 50);
        for s in &a {
            assert!(s.pos.x < 100.0 && s.pos.y < 50.0 && s.opacity == 1.0 && s.plane.is_none() && !s.carried);
        }
        assert_eq!(grid_seeds(7, 0, 10.0, 100, 50, |_| true), a);
        assert_ne!(grid_seeds(7, 1, 10.0, 100, 50, |_| true)[0].id, a[0].id);
    }
}
