//! The values of the enumerated settings, named as the JSON config and the flags spell them.
//! Each stage has enums of its own (`camera::CameraKind`, `facets::FacetMethod`...);
//! `pipeline::params` maps these onto them.

use serde::{Deserialize, Serialize};

kebab_enum!(
    /// The camera model.
    CameraKind {
        /// Spherical for compact scenes, cylindrical for tall ones (height >= 1.6 x width).
        Auto = "auto",
        /// Rays start on a sphere and converge on the focal centre (eq 4.2).
        Spherical = "spherical",
        /// Rays converge on a vertical focal line; rows map linearly to height.
        Cylindrical = "cylindrical",
        /// Rays start on a plane and converge on a focal point (eq 4.1).
        Planar = "planar",
        /// Pinhole camera; `ambiguity` is its vertical field of view.
        Perspective = "perspective",
        /// Parallel rays.
        Orthographic = "orthographic",
    }
);

kebab_enum!(
    /// Where a cubist camera's focal centre goes when no focus distance is given.
    Framing {
        /// Behind the scene's centre, so the whole scene fits the convergence angle.
        Fit = "fit",
        /// At the centre of the scene's bounding box (the thesis's literal default).
        Centre = "centre",
        /// Per scene: C as close behind the scene as the cameras allow, the horizontal and
        /// vertical spans fitted to it, so the subject fills the canvas (`framing::compose`).
        Compose = "compose",
    }
);

kebab_enum!(
    /// How the image is split into facets.
    Faceting {
        /// One facet: the unfaceted cubist view.
        None = "none",
        /// A user's facet map image, each distinct colour a facet.
        Constant = "constant",
        /// Nearest of k stratified random points.
        Voronoi = "voronoi",
        /// Random quadrilaterals painted until every pixel is covered.
        Patch = "patch",
        /// Multiscale normalized-cut segments of the pre-render, selected by saliency.
        Segment = "segment",
        /// Straight-edged planes tiling the whole canvas, denser at salient parts, cut along
        /// the subject's outlines (`facets::planes`).
        Planes = "planes",
    }
);

kebab_enum!(
    /// How each facet's view is re-aimed.
    Imprecision {
        /// Towards the facet's saliency centre (eq 4.5).
        Saliency = "saliency",
        /// Towards a random point within the discontinuity radius (User Study I baseline).
        Random = "random",
        /// Not re-aimed.
        None = "none",
    }
);

kebab_enum!(
    /// The rays of a re-aimed facet.
    FacetProjection {
        /// Keep converging on the facet's new focal point (discontinuity 0 = unfaceted).
        Converging = "converging",
        /// Size-keeping linear facets of eq 4.6 (orthographic at facet_fov 0).
        Linear = "linear",
    }
);

kebab_enum!(
    /// How facets move over the frames of an animation.
    FacetMotion {
        /// Fixed on the image, as the thesis animates: the layout frame's facets in every frame.
        Static = "static",
        /// Carried with the surfaces they show: each surface point keeps its facet from the layout frame.
        Follow = "follow",
    }
);

kebab_enum!(
    /// Built-in palettes: luminance-ordered colour ramps written for this project (`paint::palette`).
    Palette {
        None = "none",
        /// Picasso and Braque, 1910: umber, ochre, lead white.
        Ochre = "ochre",
        /// Picasso and Braque, 1910-11: umber and ochre at the lit centre, cool greys and
        /// grey-greens towards the edges, each plane one hue at its own value.
        OchreGrey = "ochre-grey",
        /// Grisaille, 1911: warm blacks, brownish and cool greys.
        Grey = "grey",
        /// Picasso's blue period: Prussian blue to pale blue-grey.
        BluePeriod = "blue-period",
        /// Braque, 1908-09: olive and earth greens to pale ochre.
        Olive = "olive",
    }
);

kebab_enum!(
    /// How facet borders are drawn (`border_width`, `border_strength`).
    BorderStyle {
        /// Eq 4.8 on both sides of every facet border, as the thesis prints it.
        Symmetric = "symmetric",
        /// Facet borders and object silhouettes darkened on one side only, the darker one,
        /// with a hard edge; lines come and go, and where they go the planes blend (passage).
        Passage = "passage",
    }
);

kebab_enum!(
    /// How mesh saliency's Gaussian means are evaluated.
    SaliencyMethod {
        /// Exact while the exact sums' work, counted on the mesh, stays under 5e7 pairs (~0.5 s), clustered above.
        Auto = "auto",
        /// The definition's exact sums, whatever the mesh's size.
        Exact = "exact",
        /// Each block of vertices exact or by clusters (cells of sigma / 4), whichever is cheaper: bounded cost, approximate.
        Clustered = "clustered",
    }
);

kebab_enum!(
    /// Extra images written beside the output (`out.<pass>.png`).
    Pass {
        /// The per-pixel saliency map, grey.
        Saliency = "saliency",
        /// Facet ids as colours, with facet centres and saliency centres marked.
        Facets = "facets",
        /// Facet ids as 16-bit grey values (for compositing).
        FacetIds = "facet-ids",
        /// Each segmentation level and the final layout (Segment faceting).
        Segments = "segments",
        /// Object ids as colours.
        Objects = "objects",
        /// Shading normals as colours.
        Normals = "normals",
        /// Hit distance, grey, near = white.
        Depth = "depth",
        /// Animation frames only: each pixel's screen motion from the previous frame and to
        /// the next, 16-bit RGBA (Blender's Vector pass layout; docs/animation.md).
        Motion = "motion",
    }
);
