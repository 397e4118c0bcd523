//! Mesh saliency (Lee, Varshney, Jacobs 2005; SPEC "Mesh saliency") and the per-pixel
//! saliency map.
