//! Base-colour textures: decoded once to linear RGBA, sampled with the glTF sampler's wrap and filter.

use glam::{Vec2, Vec4};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    Clamp,
    Mirror,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    Linear,
}

#[derive(Clone, Debug)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// 8-bit sRGB RGBA as decoded, row 0 at the top (glTF UV (0, 0) is the top-left corner);
    /// decoded to linear per texel read (4 bytes a texel instead of 16: a scene's textures
    /// may hold `util::limits::MAX_SCENE_TEXELS`).
    pub pixels: Vec<[u8; 4]>,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub filter: Filter,
}

/// sRGB transfer function, decoding (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// The sRGB decoding of every 8-bit value, computed once.
fn srgb_lut() -> &'static [f32; 256] {
    static LUT: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    LUT.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// sRGB transfer function, encoding.
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

impl Texture {
    /// From 8-bit sRGB RGBA rows (colour channels decoded to linear, alpha kept linear).
    pub fn from_srgba8(width: u32, height: u32, rgba: &[u8], wrap_s: Wrap, wrap_t: Wrap, filter: Filter) -> Self {
        let pixels = rgba.chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]).collect();
        Texture { width, height, pixels, wrap_s, wrap_t, filter }
    }

    /// From decoded 8-bit sRGB RGBA texels (moved, not copied).
    pub fn from_texels(
        width: u32,
        height: u32,
        pixels: Vec<[u8; 4]>,
        wrap_s: Wrap,
        wrap_t: Wrap,
        filter: Filter,
    ) -> Self {
        Texture { width, height, pixels, wrap_s, wrap_t, filter }
    }

    fn texel(&self, x: i64, y: i64) -> Vec4 {
        let x = wrap(x, self.width as i64, self.wrap_s);
        let y = wrap(y, self.height as i64, self.wrap_t);
        let p = self.pixels[(y * self.width as i64 + x) as usize];
        let lut = srgb_lut();
        Vec4::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize], p[3] as f32 / 255.0)
    }

    /// Samples at `uv` (any real value; wrapped). Non-finite UVs read texel (0, 0).
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        // Keep coordinates in a range where f32 -> i64 is exact; wrapping is periodic anyway.
        let x = (uv.x as f64 * self.width as f64).clamp(-1e12, 1e12);
        let y = (uv.y as f64 * self.height as f64).clamp(-1e12, 1e12);
        match self.filter {
            Filter::Nearest => self.texel(x.floor() as i64, y.floor() as i64),
            Filter::Linear => {
                let (fx, fy) = (x - 0.5, y - 0.5);
                let (x0, y0) = (fx.floor(), fy.floor());
                let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let top = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), tx);
                let bottom = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), tx);
                top.lerp(bottom, ty)
            }
        }
    }
}

fn wrap(i: i64, n: i64, mode: Wrap) -> i64 {
    match mode {
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Mirror => {
            let period = 2 * n;
            let m = i.rem_euclid(period);
            if m < n { m } else { period - 1 - m }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Texture {
        // 2x2: black, white / white, black
        let px = [0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255];
        Texture::from_srgba8(2, 2, &px, Wrap::Repeat, Wrap::Repeat, Filter::Nearest)
    }

    #[test]
    fn nearest_reads_texel_centres_and_repeats() {
        let t = checker();
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)).x, 0.0);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25)).x, 1.0);
        assert_eq!(t.sample(Vec2::new(1.25, 0.25)).x, 0.0);
        assert_eq!(t.sample(Vec2::new(-0.25, 0.25)).x, 1.0);
    }

    #[test]
    fn wrap_modes() {
        assert_eq!(wrap(-1, 4, Wrap::Clamp), 0);
        assert_eq!(wrap(5, 4, Wrap::Clamp), 3);
        assert_eq!(wrap(-1, 4, Wrap::Repeat), 3);
        assert_eq!(wrap(4, 4, Wrap::Mirror), 3);
        assert_eq!(wrap(-1, 4, Wrap::Mirror), 0);
        assert_eq!(wrap(8, 4, Wrap::Mirror), 0);
    }

    #[test]
    fn linear_filter_blends_between_texels() {
        let mut t = checker();
        t.filter = Filter::Linear;
        let mid = t.sample(Vec2::new(0.5, 0.25));
        assert!((mid.x - 0.5).abs() < 1e-6);
    }

    #[test]
    fn non_finite_uv_does_not_panic() {
        let t = checker();
        for uv in [Vec2::NAN, Vec2::new(f32::INFINITY, 0.0), Vec2::new(1e30, -1e30)] {
            assert!(t.sample(uv).is_finite());
        }
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=255 {
            let c = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5);
        }
    }
}
