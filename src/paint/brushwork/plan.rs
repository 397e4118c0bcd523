//! What a session keeps of the brushwork between paint-only changes: each layer's fragments
//! (the pixels its strokes paint, with their alpha and shade), composited again under new
//! colours without testing a stroke at a pixel.

use glam::Vec4;
use rayon::prelude::*;

use super::layer::{Anchor, BAND, Stroke, StrokeLayer, Surface, Tint, each_band, lay, shape};
use crate::paint::luminance;

/// One pixel a stroke paints (`shape`'s answer, kept): the pixel (within its band), its alpha
/// before the dark accents and its shade. The stroke is its `Run`'s: 12 bytes, not 16 with
/// the stroke in each (a band lists a stroke's pixels together, `each_band`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Fragment {
    pub(super) pixel: u32,
    pub(super) alpha: f32,
    pub(super) shade: f32,
}

/// A stroke's fragments in a band: those up to `end` (an index into the band's fragments)
/// from the previous run's end.
#[derive(Clone, Copy, Debug)]
pub(super) struct Run {
    pub(super) stroke: u32,
    pub(super) end: u32,
}

/// One band's fragments in compositing order, grouped in runs of one stroke: a stroke left
/// out (the fine layer's, where its test does not keep it) is skipped without reading its
/// fragments.
#[derive(Default)]
pub(super) struct Band {
    pub(super) runs: Vec<Run>,
    pub(super) fragments: Vec<Fragment>,
}

impl Band {
    pub(super) fn push(&mut self, stroke: u32, f: Fragment) {
        self.fragments.push(f);
        let end = self.fragments.len() as u32;
        match self.runs.last_mut() {
            Some(r) if r.stroke == stroke => r.end = end,
            _ => self.runs.push(Run { stroke, end }),
        }
    }

    /// Each run's stroke and fragments, in order.
    pub(super) fn runs(&self) -> impl Iterator<Item = (u32, &[Fragment])> {
        let mut start = 0usize;
        self.runs.iter().map(move |r| {
            let frags = &self.fragments[start..r.end as usize];
            start = r.end as usize;
            (r.stroke, frags)
        })
    }

    pub(super) fn bytes(&self) -> usize {
        self.fragments.capacity() * size_of::<Fragment>() + self.runs.capacity() * size_of::<Run>()
    }
}

/// A layer's strokes and where they paint, per band in compositing order: what does not
/// depend on the picture's colours, only on the regions, the planes and the strokes' size and
/// opacity. A session keeps it (`StrokePlan`), so a change of colour upstream (a border width,
/// a palette) composites these fragments instead of testing every stroke at every pixel.
pub(super) struct Fragments {
    pub(super) layer: StrokeLayer,
    pub(super) bands: Vec<Band>,
}

impl Fragments {
    /// The fragments of `layer`'s strokes, compositing them (tinted `tints`, each at its
    /// `active` share when given) over `px` on the way, as `composite` does.
    pub(super) fn build(
        layer: StrokeLayer,
        surface: &Surface,
        opacity: f32,
        tints: &[Tint],
        active: Option<&[f32]>,
        px: &mut [Vec4],
    ) -> Fragments {
        let w = surface.w;
        // Each band's room for its fragments, from the strokes' mean cover (their area over
        // the image's) with a margin: pushing into it does not move it as it grows (only the
        // pages written are touched).
        let area: f64 = layer.strokes.iter().map(|s| 4.0 * s.half_len as f64 * (s.half_wid as f64 + 0.5)).sum();
        let room = (1.15 * area / (w * surface.h).max(1) as f64 * (BAND * w) as f64) as usize + 64;
        let mut bands: Vec<Band> = (0..surface.h.div_ceil(BAND))
            .map(|_| Band { runs: Vec::new(), fragments: Vec::with_capacity(room) })
            .collect();
        let regions = surface.regions;
        each_band(
            &layer,
            surface,
            bands.iter_mut().zip(px.chunks_mut(BAND * w.max(1))).collect(),
            // The band's regions, and each pixel's luminance before the layer.
            |y0, (_, pixels)| {
                (&regions[y0 * w..], pixels.iter().map(|p| luminance(p.truncate())).collect::<Vec<f32>>())
            },
            |(out, pixels), (regions, value), i, k, dx, dy_dir| {
                if let Some((alpha, shade)) = shape(&layer.strokes[k as usize], dx, dy_dir, regions[i], opacity) {
                    out.push(k, Fragment { pixel: i as u32, alpha, shade });
                    let share = active.map_or(1.0, |a| a[k as usize]);
                    if share > 0.0 {
                        let p = &mut pixels[i];
                        *p = lay(&tints[k as usize], value[i], p.truncate(), alpha * share, shade).extend(p.w);
                    }
                }
            },
        );
        Fragments { layer, bands }
    }

    pub(super) fn bytes(&self) -> usize {
        self.bands.iter().map(Band::bytes).sum::<usize>()
            + self.layer.strokes.len() * size_of::<Stroke>()
            + self.layer.cells.len() * size_of::<Anchor>()
            + (self.layer.items.len() + self.layer.start.len() + self.layer.cell_of.len()) * 4
    }

    /// `composite` from the kept fragments: the same pixels.
    pub(super) fn composite(&self, tints: &[Tint], active: Option<&[f32]>, px: &mut [Vec4], w: usize) {
        px.par_chunks_mut(BAND * w).zip(&self.bands).for_each(|(pixels, band)| {
            let value: Vec<f32> = pixels.iter().map(|p| luminance(p.truncate())).collect();
            for (k, frags) in band.runs() {
                let share = active.map_or(1.0, |a| a[k as usize]);
                if share <= 0.0 {
                    continue;
                }
                let t = &tints[k as usize];
                for f in frags {
                    let i = f.pixel as usize;
                    let p = &mut pixels[i];
                    *p = lay(t, value[i], p.truncate(), f.alpha * share, f.shade).extend(p.w);
                }
            }
        });
    }
}

/// What a session keeps of the brushwork between paint-only changes (`PaintInputs`): both
/// layers' fragments, the fine layer's for every cell (which cells paint depends on the
/// colours), for one stroke size, opacity and seed on an opaque canvas.
pub struct StrokePlan {
    pub(super) key: [u64; 3],
    pub(super) coarse: Fragments,
    pub(super) fine: Option<Fragments>,
}

impl StrokePlan {
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.coarse.bytes() + self.fine.as_ref().map_or(0, Fragments::bytes)
    }
}
