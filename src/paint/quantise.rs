//! Quantisation to K colours (thesis 4.4: "Picasso and Braque commonly used a limited number
//! of colours; fine details were composed through a difference in luminance rather than hue").
//! Luminance-preserving: the pixels are clustered by luminance alone (1-D k-means: Lloyd's
//! iterations from quantile seeds, on the luminance-key histogram), and each cluster
//! is painted with its pixels' mean colour, whose luminance is their mean luminance.
//!
//! Each luminance level weighs the square root of its pixel count in the clustering: with
//! plain counts a large flat area (the background, a facet of one tone) draws several
//! clusters to itself and the shaded forms are left with one or two tones; with equal weights
//! a few stray pixels get their own colour. The square root sits between the two.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::{Canvas, Effect, EffectParams, LuminanceKeys, PaintContext, UNPAINTED};
use crate::error::Result;

/// The quantisation's parameters: the number of colours (0 = off).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct QuantiseParams {
    pub colors: u32,
}

impl EffectParams for QuantiseParams {
    fn is_on(&self) -> bool {
        self.colors > 0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Quantise { colors: self.colors }))
    }
}

/// Lloyd iterations at most (1-D k-means converges in a few dozen).
const MAX_ITERATIONS: usize = 100;

/// Reduces the painted pixels to at most `colors` colours.
pub struct Quantise {
    pub colors: u32,
}

/// Partitions the keys (with `weights`) into at most `k` luminance intervals that locally
/// minimise the weighted squared key error: returns the cluster of every key.
pub fn cluster_keys(weights: &[f64], k: usize) -> Vec<u32> {
    let histogram = weights;
    let total: f64 = histogram.iter().sum();
    let mut centres: Vec<f64> = Vec::with_capacity(k);
    if total > 0.0 {
        // Quantile seeds; equal seeds (a key holding much weight) merge.
        let mut before = 0.0f64;
        let mut j = 0usize;
        for (key, &c) in histogram.iter().enumerate() {
            before += c;
            while j < k && ((j as f64 + 0.5) / k as f64) * total < before {
                if centres.last() != Some(&(key as f64)) {
                    centres.push(key as f64);
                }
                j += 1;
            }
        }
    }
    if centres.is_empty() {
        return vec![0; histogram.len()];
    }
    // Prefix sums of weights and of key x weight make each iteration O(k).
    let mut cum_n = vec![0f64; histogram.len() + 1];
    let mut cum_s = vec![0f64; histogram.len() + 1];
    for (key, &c) in histogram.iter().enumerate() {
        cum_n[key + 1] = cum_n[key] + c;
        cum_s[key + 1] = cum_s[key] + c * key as f64;
    }
    let bounds = |centres: &[f64]| -> Vec<usize> {
        // Interval j holds keys in [b[j], b[j+1]): nearest centre, ties to the lower one.
        let mut b = Vec::with_capacity(centres.len() + 1);
        b.push(0);
        for w in centres.windows(2) {
            b.push((((w[0] + w[1]) * 0.5).floor() as usize + 1).min(histogram.len()));
        }
        b.push(histogram.len());
        b
    };
    for _ in 0..MAX_ITERATIONS {
        let b = bounds(&centres);
        let mut next = Vec::with_capacity(centres.len());
        for j in 0..centres.len() {
            let n = cum_n[b[j + 1]] - cum_n[b[j]];
            if n > 0.0 {
                next.push((cum_s[b[j + 1]] - cum_s[b[j]]) / n);
            }
        }
        next.dedup();
        if next == centres {
            break;
        }
        centres = next;
    }
    let b = bounds(&centres);
    let mut cluster = vec![0u32; histogram.len()];
    for j in 0..centres.len() {
        cluster[b[j]..b[j + 1]].fill(j as u32);
    }
    cluster
}

impl Effect for Quantise {
    fn name(&self) -> &'static str {
        "quantise"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, _ctx: &PaintContext) -> Result<()> {
        let keys = LuminanceKeys::new(canvas);
        if keys.total == 0 {
            return Ok(());
        }
        let weights: Vec<f64> = keys.histogram.iter().map(|&c| (c as f64).sqrt()).collect();
        let cluster = cluster_keys(&weights, self.colors as usize);
        let k = cluster.iter().copied().max().unwrap_or(0) as usize + 1;
        // Mean colour per cluster; fixed chunks summed in order, so any thread count gives
        // the same bits.
        const CHUNK: usize = 1 << 14;
        let partial: Vec<Vec<(DVec3, u64)>> = canvas
            .px
            .par_chunks(CHUNK)
            .zip(keys.keys.par_chunks(CHUNK))
            .map(|(px, ks)| {
                let mut acc = vec![(DVec3::ZERO, 0u64); k];
                for (p, key) in px.iter().zip(ks) {
                    if *key != UNPAINTED {
                        let a = &mut acc[cluster[*key as usize] as usize];
                        a.0 += p.truncate().as_dvec3();
                        a.1 += 1;
                    }
                }
                acc
            })
            .collect();
        let mut sums = vec![(DVec3::ZERO, 0u64); k];
        for part in &partial {
            for (s, p) in sums.iter_mut().zip(part) {
                s.0 += p.0;
                s.1 += p.1;
            }
        }
        let colours: Vec<Vec3> =
            sums.iter().map(|(s, n)| if *n > 0 { (*s / *n as f64).as_vec3() } else { Vec3::ZERO }).collect();
        canvas.px.par_iter_mut().zip(&keys.keys).for_each(|(p, key)| {
            if *key != UNPAINTED {
                *p = colours[cluster[*key as usize] as usize].extend(p.w);
            }
        });
        Ok(())
    }
}
