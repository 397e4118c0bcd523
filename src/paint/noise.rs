//! Smooth seeded noise for the paint (passage's lost-and-found lines, brush bristles, the
//! canvas weave): value noise on an integer lattice, hashed with splitmix64, so every value
//! depends only on (seed, position), never on evaluation order or thread count.

use crate::util::rng::{splitmix64, unit_f64};

/// A uniform number in [0, 1) for lattice point (i, j) of stream `seed` (one splitmix64 of
/// the point's coordinates spread by odd constants: plenty for textures, and cheap).
pub fn lattice(seed: u64, i: i64, j: i64) -> f32 {
    let k = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    unit_f64(splitmix64(seed ^ k)) as f32
}

/// A uniform number in [0, 1) for integer `i` of stream `seed`.
pub fn lattice1(seed: u64, i: i64) -> f32 {
    unit_f64(splitmix64(seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))) as f32
}

fn fade(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// 2-D value noise in [0, 1), smooth, one lattice cell per unit of (x, y).
pub fn value2(seed: u64, x: f32, y: f32) -> f32 {
    let (fx, fy) = (x.floor(), y.floor());
    let (i, j) = (fx as i64, fy as i64);
    let (tx, ty) = (fade(x - fx), fade(y - fy));
    let a = lattice(seed, i, j) + (lattice(seed, i + 1, j) - lattice(seed, i, j)) * tx;
    let b = lattice(seed, i, j + 1) + (lattice(seed, i + 1, j + 1) - lattice(seed, i, j + 1)) * tx;
    a + (b - a) * ty
}

/// `value2` over a fixed range of lattice cells with the lattice values computed once: the
/// very same numbers as `value2` (same operations on the same values), for effects that
/// evaluate it at every pixel.
pub struct Grid2 {
    i0: i64,
    j0: i64,
    nx: usize,
    values: Vec<f32>,
}

impl Grid2 {
    /// The lattice of stream `seed` for points with `x` in [x0, x1] and `y` in [y0, y1].
    pub fn new(seed: u64, (x0, x1): (f32, f32), (y0, y1): (f32, f32)) -> Grid2 {
        let (i0, j0) = (x0.floor() as i64, y0.floor() as i64);
        let nx = (x1.floor() as i64 - i0 + 2).max(2) as usize;
        let ny = (y1.floor() as i64 - j0 + 2).max(2) as usize;
        let values = (0..ny * nx).map(|k| lattice(seed, i0 + (k % nx) as i64, j0 + (k / nx) as i64)).collect();
        Grid2 { i0, j0, nx, values }
    }

    /// `value2(seed, x, y)`; falls back to it outside the range given.
    pub fn value2(&self, seed: u64, x: f32, y: f32) -> f32 {
        let (fx, fy) = (x.floor(), y.floor());
        let (i, j) = (fx as i64 - self.i0, fy as i64 - self.j0);
        let ny = self.values.len() / self.nx;
        if i < 0 || j < 0 || i as usize + 1 >= self.nx || j as usize + 1 >= ny {
            return value2(seed, x, y);
        }
        let k = j as usize * self.nx + i as usize;
        let (l00, l10, l01, l11) =
            (self.values[k], self.values[k + 1], self.values[k + self.nx], self.values[k + self.nx + 1]);
        let (tx, ty) = (fade(x - fx), fade(y - fy));
        let a = l00 + (l10 - l00) * tx;
        let b = l01 + (l11 - l01) * tx;
        a + (b - a) * ty
    }
}

/// 1-D value noise in [0, 1), smooth, one lattice cell per unit of x.
pub fn value1(seed: u64, x: f32) -> f32 {
    let fx = x.floor();
    let i = fx as i64;
    let a = lattice1(seed, i);
    a + (lattice1(seed, i + 1) - a) * fade(x - fx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_bounded_smooth_and_seeded() {
        let mut prev = value2(3, 0.0, 0.0);
        for k in 1..2000 {
            let x = k as f32 * 0.01;
            let v = value2(3, x, 0.37 * x);
            assert!((0.0..1.0).contains(&v));
            assert!((v - prev).abs() < 0.05, "smooth: {prev} -> {v}");
            prev = v;
            let u = value1(5, x);
            assert!((0.0..1.0).contains(&u));
        }
        assert_eq!(value2(3, 1.0, 2.0), lattice(3, 1, 2));
        assert_ne!(value2(3, 0.5, 0.5), value2(4, 0.5, 0.5));
    }

    #[test]
    fn the_grid_gives_value2_bit_for_bit() {
        let g = Grid2::new(9, (0.0, 12.5), (-1.0, 7.0));
        for k in 0..5000 {
            let (x, y) = (k as f32 * 0.0037 - 2.0, (k % 97) as f32 * 0.11 - 3.0);
            assert_eq!(g.value2(9, x, y).to_bits(), value2(9, x, y).to_bits(), "{x} {y}");
        }
    }
}
