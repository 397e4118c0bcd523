//! What the frames of an animation hold still: what one frame's picture alone would decide
//! (a palette's ranks, which planes open across the outline, a plane's mean colour) is
//! decided once, on the layout frame, and read by every frame, so that a pixel whose surface
//! point and light do not change keeps its bytes while the subject moves elsewhere.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use super::{palette, plane_light};
use crate::facets::FacetMap;

/// What animation frames hold still across a sequence, so that what does not move in the
/// scene does not change in the picture (`Painter::apply_sequence`).
#[derive(Clone, Copy, Default)]
pub struct Sequence<'a> {
    /// What the layout frame's picture decided (`Painter::hold`).
    pub held: Option<&'a Held>,
    /// The facet map the planes are read from (the layout's), instead of the frame's own.
    pub planes_from: Option<&'a FacetMap>,
    /// Per facet id, how far its plane moved since `planes_from` (pixels; facets that follow
    /// the scene: `facets::motion::Carried::shift`).
    pub plane_shift: Option<&'a [Vec2]>,
    /// Facets that follow, carried from a key frame after the layout frame: the layout's
    /// facet map and, per facet id, whether it is one of the still background's facets
    /// (`facets::motion::still_facets`), whose planes are read from the layout, so a new key
    /// frame does not turn the still background's ramps and strokes.
    pub still_planes: Option<(&'a FacetMap, &'a [bool])>,
    /// Facets that follow: per pixel, where its surface point was on the key frame's picture
    /// (NaN where the key frame did not see it: `facets::motion::Carried::at_key`), so what is
    /// laid on a plane is read there and moves with the surface (`PaintContext::plane_point`).
    pub at_key: Option<&'a [Vec2]>,
    /// Where strokes go (`strokes::surface`), instead of the still's grid.
    pub seeds: Option<&'a dyn crate::strokes::SeedSource>,
    /// The composition's light centre (the layout frame's subject), instead of the frame's own
    /// subject: a moving subject would relight the still background.
    pub oval: Option<plane_light::Oval>,
}

/// A region's mean colour (linear RGB) by region (facet << 32 | object,
/// `PaintContext::regions`).
pub type RegionMeans = HashMap<u64, Vec3>;

/// What the layout frame's picture decides for every frame of a sequence, each of which a
/// frame's own picture would change as the subject moves:
/// - the palette's luminance mapping: ranked on each frame's pixels, a moving subject shifts
///   every pixel's rank;
/// - which planes are open across the subject's outline (`PaintContext::regions`): decided
///   on each frame, a plane the subject walks into or out of would flip, and its strokes and
///   edges with it;
/// - each plane's share of ground, which deepens its light (`plane_light::GROUND`): a
///   background plane the subject walks into would change its light over all its pixels;
/// - the mean colour the brushwork draws a stroke towards, for the regions of the background
///   and of the open planes: a background plane the subject walks into loses the pixels the
///   subject covers, and its mean, hence every stroke of the plane, would change;
/// - the median plane's size, against which the brushwork sizes each plane's strokes: a new
///   key frame re-plans the subject's planes, which would move it, and every stroke with it.
///
/// The subject's own regions keep their frame's means: they move with the subject.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Held {
    pub palette: Option<palette::PaletteKey>,
    /// Per facet id: whether the plane is open (one region across the outline).
    pub open: Option<Vec<bool>>,
    /// Per facet id: the plane's share of ground (`PaintContext::ground_shares`).
    pub ground: Option<Vec<f32>>,
    /// The region means of the background's and the open planes' regions, as the brushwork
    /// reads the picture (the strokes go towards them; passage weighs a join's sides by them).
    pub means: Option<RegionMeans>,
    /// The median plane's pixels, which the brushwork sizes each plane's strokes against
    /// (`brushwork::plane_scales`).
    pub plane_median: Option<f32>,
}
