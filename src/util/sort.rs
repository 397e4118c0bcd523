//! Sorting by buckets: a counting sort on a key's leading bits, then each small bucket sorted.

use rayon::prelude::*;

/// Sorts `v` ascending, as `sort_unstable` does, given `bucket`: a bucket number below
/// `buckets` that never decreases along the order (a < b implies bucket(a) <= bucket(b)), such
/// as a key's leading bits. A counting sort by bucket, then each bucket sorted on its own (in
/// parallel), instead of a comparison sort of the whole: on a million entries spread over
/// ~2^16 buckets, each bucket fits in the L1 cache. Equal elements are indistinguishable, so
/// the result is the one any sort gives. Large buckets (an uneven spread) are sorted in
/// parallel themselves.
pub fn sort_by_buckets<T, B>(v: &mut Vec<T>, buckets: usize, bucket: B)
where
    T: Ord + Copy + Send + Sync,
    B: Fn(&T) -> usize + Sync,
{
    if v.len() < 2 * 1024 || buckets < 2 {
        v.par_sort_unstable();
        return;
    }
    // Buckets computed twice (counting, placing) rather than stored: the only extra memory
    // is the sorted copy.
    let mut start = vec![0usize; buckets + 1];
    for x in v.iter() {
        start[bucket(x) + 1] += 1;
    }
    for i in 0..buckets {
        start[i + 1] += start[i];
    }
    let mut out: Vec<T> = Vec::with_capacity(v.len());
    {
        let spare = out.spare_capacity_mut();
        let mut next = start.clone();
        for x in v.iter() {
            let b = bucket(x);
            spare[next[b]].write(*x);
            next[b] += 1;
        }
        // Every bucket filled exactly (a `bucket` giving other answers the second time panics).
        assert!((0..buckets).all(|b| next[b] == start[b + 1]), "sort_by_buckets: bucket changed");
    }
    // SAFETY: each bucket b's slots start[b]..start[b + 1] were written in turn (checked just
    // above), and those ranges tile 0..v.len().
    unsafe { out.set_len(v.len()) };
    // The input's memory goes back before the buckets are sorted.
    *v = Vec::new();
    // Each bucket's range, split off in turn, sorted independently.
    let mut ranges: Vec<&mut [T]> = Vec::new();
    let mut rest: &mut [T] = &mut out;
    for b in 0..buckets {
        let (head, tail) = rest.split_at_mut(start[b + 1] - start[b]);
        if head.len() > 1 {
            ranges.push(head);
        }
        rest = tail;
    }
    ranges.into_par_iter().for_each(|r| {
        if r.len() > 1 << 16 {
            r.par_sort_unstable();
        } else {
            r.sort_unstable();
        }
    });
    *v = out;
}

/// The bucket of a u64 key among 2^`bits` by its leading bits below `max` (the largest key):
/// the shift to apply, so that `max >> shift` < 2^`bits`.
pub fn leading_bits_shift(max: u64, bits: u32) -> u32 {
    (64 - max.leading_zeros()).saturating_sub(bits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::splitmix64;

    fn check<T: Ord + Copy + Send + Sync + std::fmt::Debug>(
        v: Vec<T>,
        buckets: usize,
        bucket: impl Fn(&T) -> usize + Sync,
    ) {
        let mut want = v.clone();
        want.sort_unstable();
        let mut got = v;
        sort_by_buckets(&mut got, buckets, bucket);
        assert_eq!(got, want);
    }

    #[test]
    fn sorts_as_a_comparison_sort_does() {
        for n in [0usize, 1, 5, 3000, 100_000] {
            // Hashes with ids (the BVH's duplicate check), some repeated.
            let pairs: Vec<(u64, u32)> = (0..n as u32).map(|i| (splitmix64((i % 997 + i / 3) as u64), i)).collect();
            check(pairs, 1 << 16, |p| (p.0 >> 48) as usize);
            // Small keys (cells), crowded into few buckets, and all into one.
            let cells: Vec<(u64, u32)> = (0..n as u32).map(|i| (splitmix64(i as u64) % 50_000, n as u32 - i)).collect();
            let shift = leading_bits_shift(49_999, 8);
            check(cells.clone(), 256, |p| (p.0 >> shift) as usize);
            check(cells, 1, |_| 0);
            // Triples with duplicates, bucketed by their first entry.
            let tris: Vec<[u32; 3]> = (0..n as u64)
                .map(|i| {
                    let h = splitmix64(i / 2);
                    [(h % 1000) as u32, (h >> 20) as u32 % 7, (h >> 40) as u32 % 5]
                })
                .collect();
            check(tris, 1000, |t| t[0] as usize);
        }
    }

    #[test]
    fn shift_keeps_the_largest_key_in_range() {
        assert_eq!(leading_bits_shift(0, 16), 0);
        assert_eq!(leading_bits_shift(65_535, 16), 0);
        assert_eq!(leading_bits_shift(65_536, 16), 1);
        assert_eq!(leading_bits_shift(u64::MAX, 16), 48);
        for max in [1u64, 77, 1 << 40, (1 << 62) + 5] {
            assert!(max >> leading_bits_shift(max, 10) < 1 << 10);
        }
    }
}
