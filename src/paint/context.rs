//! What the effects work on and read: the canvas (the frame's colour, in place), the lights
//! the render used, what animation frames hold still, and the context handed to each effect.

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::inputs::PaintInputs;
use super::sequence::{Held, Sequence};
use super::{chiaroscuro, palette, plane_light};
use crate::facets::FacetMap;
use crate::film::PixelHit;
use crate::scene::World;
use crate::shading::LightRig;

/// The image the effects work on, in place on the frame's colour buffer (row 0 at the top).
/// Each pixel's `xyz` is, on an opaque canvas, the composited colour (linear RGB) and, on a
/// transparent one, the straight (not premultiplied) colour of the painted layer, meaningful
/// where `w > 0`. Its `w` is the coverage on an opaque canvas (never changed) and the painted
/// layer's alpha on a transparent one (darkening effects raise it).
pub struct Canvas<'a> {
    pub width: u32,
    pub height: u32,
    pub px: &'a mut [Vec4],
    /// Transparent canvases: each pixel's rendered coverage (the layer alpha changes).
    /// Opaque canvases keep it in `px[i].w`.
    pub(super) coverage: Option<Vec<f32>>,
    /// The render's background colour (linear RGB).
    pub background: Vec3,
    /// Whether the output has a transparent background (see the module doc).
    pub transparent: bool,
}

impl<'a> Canvas<'a> {
    /// Paints on `color` (a frame's colour buffer, as `render` writes it): an opaque canvas
    /// uses it as it is; a transparent one un-blends the background first.
    pub fn new(width: u32, height: u32, color: &'a mut [Vec4], background: [f32; 3], transparent: bool) -> Canvas<'a> {
        let bg = Vec3::from(background);
        let coverage = transparent.then(|| {
            let cov = color.par_iter().map(|c| c.w).collect();
            color.par_iter_mut().for_each(|c| {
                let a = c.w;
                let rgb = if a > 0.0 { (c.truncate() - bg * (1.0 - a)) / a } else { Vec3::ZERO };
                *c = rgb.extend(a);
            });
            cov
        });
        Canvas { width, height, px: color, coverage, background: bg, transparent }
    }

    /// Puts the colour back in the form `output::encode` reads: premultiplied + (1 - alpha)
    /// x background on a transparent canvas (an opaque one already is).
    pub fn finish(self) {
        if self.transparent {
            let bg = self.background;
            self.px.par_iter_mut().for_each(|c| *c = (c.truncate() * c.w + bg * (1.0 - c.w)).extend(c.w));
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.px.len()
    }

    /// The rendered coverage of every pixel, and the pixels (split borrows for parallel loops).
    pub fn coverage_and_pixels(&mut self) -> (Coverage<'_>, &mut [Vec4]) {
        (Coverage(self.coverage.as_deref()), &mut *self.px)
    }

    /// Multiplies the colour (not the alpha) of every painted pixel (`Coverage::is_painted`)
    /// by `factor(x, y)`, rows in parallel: the plane light's and the canvas grain's step,
    /// whether their factors are computed on the spot or kept (`PaintContext::factors`).
    pub fn scale_painted(&mut self, factor: impl Fn(usize, usize) -> f32 + Sync) {
        let w = self.width as usize;
        let (coverage, px) = self.coverage_and_pixels();
        px.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| {
            for (x, p) in row.iter_mut().enumerate() {
                if coverage.is_painted(y * w + x) {
                    *p = (p.truncate() * factor(x, y)).extend(p.w);
                }
            }
        });
    }
}

/// Reads a pixel's rendered coverage (see `Canvas::coverage_and_pixels`).
#[derive(Clone, Copy)]
pub struct Coverage<'a>(pub(super) Option<&'a [f32]>);

impl Coverage<'_> {
    pub fn of(&self, i: usize, p: &Vec4) -> f32 {
        self.0.map_or(p.w, |c| c[i])
    }

    /// Whether colour effects may repaint pixel `i`: everything on an opaque canvas, what was
    /// rendered (coverage > 0) on a transparent one, so a silhouette's black stays black.
    pub fn is_painted(&self, i: usize) -> bool {
        self.0.is_none_or(|c| c[i] > 0.0)
    }
}

/// Multiplies the whole pixel (foreground and background) by `f` in [0, 1]. On a transparent
/// canvas, as black laid over the pixel with alpha 1 - f.
pub fn darken(p: &mut Vec4, f: f32, transparent: bool) {
    if !transparent {
        *p = (p.truncate() * f).extend(p.w);
        return;
    }
    let a = p.w;
    let a2 = 1.0 - f * (1.0 - a);
    if a2 > 0.0 {
        *p = (p.truncate() * (f * a / a2)).extend(a2);
    }
}

/// Multiplies only the background part (1 - `coverage`) of the pixel by `f` in [0, 1].
/// Opaque: that part is still the plain background colour `bg` (silhouettes run before any
/// effect that repaints the background). Transparent: black with alpha under the unchanged
/// foreground.
pub fn darken_background(p: &mut Vec4, coverage: f32, f: f32, bg: Vec3, transparent: bool) {
    if !transparent {
        let rgb = (p.truncate() - bg * ((1.0 - coverage) * (1.0 - f))).max(Vec3::ZERO);
        *p = rgb.extend(p.w);
        return;
    }
    let a = p.w;
    let a2 = a + (1.0 - a) * (1.0 - f);
    if a2 > 0.0 {
        *p = (p.truncate() * (a / a2)).extend(a2);
    }
}

/// The scene's lights as the render used them (chiaroscuro relights with them).
pub struct Lighting<'a> {
    pub world: &'a World,
    pub rig: &'a LightRig,
    /// The camera's axes: chiaroscuro turns each facet's lights about the view axis.
    pub view: chiaroscuro::ViewAxes,
}

/// What the effects read besides the canvas.
pub struct PaintContext<'a> {
    /// The representative hit of every pixel (normals for chiaroscuro).
    pub hits: &'a [PixelHit],
    /// Facet id of every pixel; None = one facet (faceting none).
    pub facets: Option<&'a FacetMap>,
    pub lighting: Option<&'a Lighting<'a>>,
    /// What several effects derive from the facet map and the hits alone, computed once.
    pub(super) inputs: &'a PaintInputs,
    /// `PaintParams::open_planes`.
    pub(super) open_planes: bool,
    /// Animation frames: what holds still across the sequence.
    pub(super) sequence: Option<&'a Sequence<'a>>,
}

impl<'a> PaintContext<'a> {
    /// Where the composition's light is centred: the sequence's, else this picture's subject.
    pub fn oval(&self, width: usize, height: usize) -> plane_light::Oval {
        self.sequence.and_then(|s| s.oval).unwrap_or_else(|| plane_light::Oval::of(width, height, self.hits))
    }

    /// Animation frames: what the layout frame's picture fixed for the sequence.
    pub fn held(&self) -> Option<&Held> {
        self.sequence.and_then(|s| s.held)
    }

    /// Animation frames: the palette's mapping decided for the sequence.
    pub fn palette_key(&self) -> Option<&palette::PaletteKey> {
        self.held().and_then(|h| h.palette.as_ref())
    }

    /// Whether this is a frame of a sequence (`Sequence`).
    pub fn in_sequence(&self) -> bool {
        self.sequence.is_some()
    }

    /// Animation frames: where strokes go.
    pub fn seeds(&self) -> Option<&dyn crate::strokes::SeedSource> {
        self.sequence.and_then(|s| s.seeds)
    }

    /// Where pixel `i` of a `width`-wide picture reads its plane (the ramp, the composition's
    /// light, the line's lost and found): its centre, or, with facets that follow, where its
    /// surface point was on the key frame's picture moved by its plane's shift (the plane is
    /// the key frame's moved so: `PaintContext::planes`), so what is laid on the plane moves
    /// with the surface, not only with the plane's mean move.
    pub fn plane_point(&self, i: usize, width: usize) -> Vec2 {
        let centre = Vec2::new((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
        let Some(s) = self.sequence else { return centre };
        match s.at_key.and_then(|k| k.get(i)).filter(|q| q.is_finite()) {
            Some(q) => *q + s.plane_shift.and_then(|d| d.get(self.facet(i) as usize)).copied().unwrap_or(Vec2::ZERO),
            None => centre,
        }
    }

    /// The facet id of pixel `i` (0 without a facet map).
    pub fn facet(&self, i: usize) -> u32 {
        self.facets.map_or(0, |f| f.ids[i])
    }

    /// Number of facets (1 without a facet map), at least one more than any id.
    pub fn facet_count(&self) -> usize {
        self.facets.map_or(1, |f| f.id_bound())
    }
}
