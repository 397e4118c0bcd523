//! How a border darkens with the distance to it: the thesis's eq 4.8, shared by the drawn
//! borders and the silhouettes, and passage's drawn line.

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

/// Passage's line holds eq 4.8's darkest value over this share of md from the edge ...
pub const LINE_CORE: f32 = 0.3;
/// ... and is gone at this share: a drawn line with a crisp side against its own plane, where
/// eq 4.8's profile fades into the plane like a cast shadow (judged blind:
/// docs/look/README.md, round 48).
pub const LINE_END: f32 = 0.56;

/// Passage's line: eq 4.8's value on the border (a quarter of the colour) held to
/// `LINE_CORE` md, rising smoothly to 1 at `LINE_END` md.
pub fn drawn_line(pd: f32, md: f32) -> f32 {
    if md.is_nan() || md <= 0.0 {
        return 1.0;
    }
    0.25 + 0.75 * crate::paint::planes::smoothstep(LINE_CORE * md, LINE_END * md, pd)
}
