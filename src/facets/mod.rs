//! Facets (SPEC "Faceting"): a facet layout is a resolution-independent description of how
//! the image splits into facets, rasterised to a facet id per pixel at any size, so one layout
//! can be saved once and reused for every frame of an animation on any machine.
//!
//! A layout is drawn in three layers, each over the previous:
//! 1. `base`: a label image scaled nearest-neighbour (Constant's facet map, Segment's level-1
//!    segments, or a layout loaded from a PNG);
//! 2. `sites`: Voronoi sites; a pixel belongs to the nearest site (in pixel distance);
//! 3. `polygons`: convex or not, drawn in order, later ones occluding earlier ones (Patch's
//!    quadrilaterals, Segment's fitted quads in ascending saliency).

use serde::{Deserialize, Serialize};

pub mod segment;

/// A label raster, each value a facet id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelImage {
    pub width: u32,
    pub height: u32,
    pub labels: Vec<u32>,
}

/// A polygonal facet: vertices in normalised image coordinates ([0, 1]^2, x right, y down).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FacetPolygon {
    pub facet: u32,
    pub points: Vec<[f64; 2]>,
}

/// How an image splits into facets, independent of resolution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct FacetLayout {
    /// Number of facets; every id used is below it.
    pub facet_count: u32,
    pub base: Option<LabelImage>,
    /// Voronoi sites in normalised coordinates; site i is facet i.
    pub sites: Vec<[f64; 2]>,
    /// Drawn in order over `base` and `sites`.
    pub polygons: Vec<FacetPolygon>,
}

/// A layout rasterised at one size: the facet id of every pixel (row 0 at the top).
#[derive(Clone, Debug, PartialEq)]
pub struct FacetMap {
    pub width: u32,
    pub height: u32,
    pub ids: Vec<u32>,
    pub facet_count: u32,
}

impl FacetLayout {
    /// One facet covering the whole image (faceting `none`).
    pub fn single() -> FacetLayout {
        FacetLayout {
            facet_count: 1,
            base: None,
            sites: Vec::new(),
            polygons: vec![FacetPolygon { facet: 0, points: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] }],
        }
    }
}
