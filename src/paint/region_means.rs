//! Each region's (plane x object) mean colour over a picture: what brushwork's strokes are
//! drawn towards and what passage weighs the two sides of a join by.

use std::collections::HashMap;

use glam::{Vec3, Vec4};

use super::Coverage;
use super::sequence::RegionMeans;

/// Each region's mean colour over its painted pixels (`regions`: facet << 32 | object),
/// summed in pixel order (the same sums on any thread count).
pub fn region_means(source: &[Vec4], regions: &[u64], coverage: &Coverage) -> RegionMeans {
    let mut sums: HashMap<u64, ([f64; 3], u64)> = HashMap::new();
    for (i, (p, r)) in source.iter().zip(regions).enumerate() {
        if coverage.is_painted(i) {
            let s = sums.entry(*r).or_insert(([0.0; 3], 0));
            s.0[0] += p.x as f64;
            s.0[1] += p.y as f64;
            s.0[2] += p.z as f64;
            s.1 += 1;
        }
    }
    sums.into_iter()
        .map(|(r, (c, n))| {
            let n = n.max(1) as f64;
            (r, Vec3::new((c[0] / n) as f32, (c[1] / n) as f32, (c[2] / n) as f32))
        })
        .collect()
}
