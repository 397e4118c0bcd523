//! Pixel grids (row-major, row 0 at the top): which pixels neighbour which, and where labels
//! (facet ids, segments) change. One definition, so facet borders, the painterly border
//! effect and the inspection images agree on what a border pixel is.

/// A `width` x `height` pixel grid; pixel index = y * width + x.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    pub width: usize,
    pub height: usize,
}

impl Grid {
    pub fn new(width: u32, height: u32) -> Grid {
        Grid { width: width as usize, height: height as usize }
    }

    /// The 4-neighbours of pixel `i` inside the grid, in the order left, right, up, down.
    #[inline]
    pub fn neighbours4(self, i: usize) -> impl Iterator<Item = usize> {
        let (w, h) = (self.width, self.height);
        let (x, y) = (i % w, i / w);
        [(x > 0).then(|| i - 1), (x + 1 < w).then(|| i + 1), (y > 0).then(|| i - w), (y + 1 < h).then(|| i + w)]
            .into_iter()
            .flatten()
    }

    /// The right and lower neighbours of pixel `i` inside the grid: each 4-adjacent pair once.
    #[inline]
    pub fn forward_neighbours(self, i: usize) -> impl Iterator<Item = usize> {
        let (w, h) = (self.width, self.height);
        let (x, y) = (i % w, i / w);
        [(x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)].into_iter().flatten()
    }

    /// Whether pixel `i` touches a pixel of another label (4-neighbourhood): a border pixel,
    /// on both sides of the border.
    #[inline]
    pub fn on_border(self, labels: &[u32], i: usize) -> bool {
        let l = labels[i];
        self.neighbours4(i).any(|j| labels[j] != l)
    }

    /// Whether pixel `i`'s right or lower neighbour has another label: border pixels one pixel
    /// wide, on the upper/left side of each border.
    #[inline]
    pub fn on_border_forward(self, labels: &[u32], i: usize) -> bool {
        let l = labels[i];
        self.forward_neighbours(i).any(|j| labels[j] != l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_stay_inside_the_grid() {
        let g = Grid::new(3, 2);
        assert_eq!(g.neighbours4(0).collect::<Vec<_>>(), vec![1, 3]);
        assert_eq!(g.neighbours4(4).collect::<Vec<_>>(), vec![3, 5, 1]);
        assert_eq!(g.forward_neighbours(2).collect::<Vec<_>>(), vec![5]);
        assert_eq!(g.forward_neighbours(5).count(), 0);
    }

    #[test]
    fn borders_are_where_labels_change() {
        // 0 0 1
        // 0 0 1
        let g = Grid::new(3, 2);
        let l = [0, 0, 1, 0, 0, 1];
        let both: Vec<bool> = (0..6).map(|i| g.on_border(&l, i)).collect();
        assert_eq!(both, vec![false, true, true, false, true, true]);
        let forward: Vec<bool> = (0..6).map(|i| g.on_border_forward(&l, i)).collect();
        assert_eq!(forward, vec![false, true, false, false, true, false]);
    }
}
