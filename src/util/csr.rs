//! Compressed sparse rows of an undirected graph: the mesh's vertex adjacency (saliency) and
//! the superpixels' region graph (Segment faceting) are both built here, by a counting sort.

use std::ops::Range;

/// Each node's neighbours, node-major: row `i` is `targets[offsets[i]..offsets[i + 1]]`,
/// ascending by neighbour; `edges` gives, for each entry, the index of the edge it came from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Csr {
    pub offsets: Vec<usize>,
    pub targets: Vec<u32>,
    pub edges: Vec<u32>,
}

impl Csr {
    /// The rows of `nodes` nodes joined by undirected `edges` (a, b): each edge appears in
    /// both rows. No edge may repeat (rows are sorted by neighbour, so repeats would tie).
    pub fn from_undirected(nodes: usize, edges: &[(u32, u32)]) -> Csr {
        let mut offsets = vec![0usize; nodes + 1];
        for &(a, b) in edges {
            offsets[a as usize + 1] += 1;
            offsets[b as usize + 1] += 1;
        }
        for i in 0..nodes {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut slots = vec![(0u32, 0u32); offsets[nodes]];
        for (e, &(a, b)) in edges.iter().enumerate() {
            for (s, t) in [(a, b), (b, a)] {
                slots[fill[s as usize]] = (t, e as u32);
                fill[s as usize] += 1;
            }
        }
        for i in 0..nodes {
            slots[offsets[i]..offsets[i + 1]].sort_unstable();
        }
        let (targets, edges) = slots.into_iter().unzip();
        Csr { offsets, targets, edges }
    }

    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The entries of node `i`'s row.
    #[inline]
    pub fn row(&self, i: usize) -> Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }

    /// The neighbours of node `i`, ascending.
    #[inline]
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.targets[self.row(i)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_hold_both_ends_of_every_edge_in_ascending_order() {
        let c = Csr::from_undirected(4, &[(2, 0), (0, 1), (1, 2)]);
        assert_eq!(c.len(), 4);
        assert_eq!(c.neighbours(0), &[1, 2]);
        assert_eq!(c.neighbours(1), &[0, 2]);
        assert_eq!(c.neighbours(2), &[0, 1]);
        assert!(c.neighbours(3).is_empty());
        // Entry -> edge: node 0's neighbour 2 came from edge 0.
        assert_eq!(c.edges[c.row(0)], [1, 0]);
    }
}
