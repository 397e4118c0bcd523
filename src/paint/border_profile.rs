//! How a border darkens with the distance to it (the thesis's eq 4.8), shared by the drawn
//! borders, the silhouettes and passage's broken joins.

/// Eq 4.8: colour factor (md + 3 sqrt(p_d md)) / (4 md) for p_d in [0, md], 1 beyond:
/// a quarter of the colour on the border, rising steeply then flattening to 1 at md.
pub fn border_factor(pd: f32, md: f32) -> f32 {
    if md.is_nan() || md <= 0.0 || pd >= md {
        return 1.0;
    }
    let pd = pd.max(0.0);
    (md + 3.0 * (pd * md).sqrt()) / (4.0 * md)
}

/// Eq 4.8 with a strength s in [0, 1]: 1 - s (1 - factor); s = 1 is the equation as printed.
pub fn darkening(pd: f32, md: f32, strength: f32) -> f32 {
    1.0 - strength * (1.0 - border_factor(pd, md))
}
