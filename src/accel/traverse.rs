//! The BVH's traversal layout (children's boxes side by side, one slab test for both) and its
//! closest-hit and any-hit walks.

use super::*;

/// A BVH2 laid out for traversal: for each inner node, its two children's
/// boxes side by side, one four-lane vector per axis ([left min, right min, left max, right
/// max]), so one slab test of a few vector operations serves both children; with what each child
/// is (an inner node's own pair, or a leaf's triangles), 64 bytes, one cache line, per pair
/// instead of two 48-byte nodes. The traversal (`Pairs::traverse`) is obvhs's
/// `Bvh2::ray_traverse_dynamic` step for step: each child's entry distance is its slab test's
/// (the same subtractions, products, minima and maxima per lane), the nearer child first, the
/// same stack; so the same leaves are visited in the same order, with the same hits.
pub(super) struct Pairs {
    /// The root's box and, when the root is a leaf, its (first primitive, count).
    pub(super) root: Aabb,
    pub(super) root_leaf: Option<(u32, u32)>,
    /// Pair 0 is the root's children (when the root is inner).
    pub(super) pairs: Vec<Pair>,
    /// Longest path from the root in pairs: the most the stack holds.
    pub(super) depth: usize,
}

/// Aligned to a cache line (64 bytes): one line per pair in every run, whatever address the
/// allocation gets (at 16 bytes, most pairs straddled two lines in some runs).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct Pair {
    pub(super) x: glam::Vec4,
    pub(super) y: glam::Vec4,
    pub(super) z: glam::Vec4,
    /// Per child: its pair (inner node) or first primitive (leaf).
    pub(super) index: [u32; 2],
    /// Per child: its primitive count, 0 for an inner node.
    pub(super) count: [u32; 2],
}

impl Pairs {
    /// The pair layout of `bvh` (an empty tree: nothing is ever hit).
    pub(super) fn new(bvh: &Bvh2) -> Pairs {
        let empty = Pairs { root: Aabb::empty(), root_leaf: Some((0, 0)), pairs: Vec::new(), depth: 0 };
        let Some(root) = bvh.nodes.first() else { return empty };
        let mut out = Pairs { root: *root.aabb(), root_leaf: None, pairs: Vec::new(), depth: 0 };
        if root.is_leaf() {
            out.root_leaf = Some((root.first_index, root.prim_count));
            return out;
        }
        // Depth first: (node index of the left child, pair slot to fill, depth).
        let mut todo = vec![(root.first_index as usize, 0usize, 1usize)];
        out.pairs.push(Pair::EMPTY);
        while let Some((first, slot, depth)) = todo.pop() {
            out.depth = out.depth.max(depth);
            let (l, r) = (&bvh.nodes[first], &bvh.nodes[first + 1]);
            let (lb, rb) = (l.aabb(), r.aabb());
            let mut pair = Pair {
                x: glam::Vec4::new(lb.min.x, rb.min.x, lb.max.x, rb.max.x),
                y: glam::Vec4::new(lb.min.y, rb.min.y, lb.max.y, rb.max.y),
                z: glam::Vec4::new(lb.min.z, rb.min.z, lb.max.z, rb.max.z),
                index: [0; 2],
                count: [l.prim_count, r.prim_count],
            };
            for (k, node) in [l, r].into_iter().enumerate() {
                if node.is_leaf() {
                    pair.index[k] = node.first_index;
                } else {
                    pair.index[k] = out.pairs.len() as u32;
                    todo.push((node.first_index as usize, out.pairs.len(), depth + 1));
                    out.pairs.push(Pair::EMPTY);
                }
            }
            out.pairs[slot] = pair;
        }
        out
    }

    /// obvhs's `ray_traverse_dynamic` on this layout: `leaf(first, count, &mut ray)` is called
    /// for each leaf the ray reaches (it may lower `ray.tmax`); it returns false to stop.
    #[inline(always)]
    pub(super) fn traverse<F: FnMut(u32, u32, &mut Ray) -> bool>(&self, ray: Ray, leaf: F) {
        if self.depth <= INLINE_STACK {
            self.traverse_on(&mut InlineStack::new(), ray, leaf)
        } else {
            self.traverse_on(&mut Vec::with_capacity(self.depth), ray, leaf)
        }
    }

    /// `traverse` on `stack`.
    #[inline(always)]
    pub(super) fn traverse_on<S: NodeStack, F: FnMut(u32, u32, &mut Ray) -> bool>(
        &self,
        stack: &mut S,
        mut ray: Ray,
        mut leaf: F,
    ) {
        if !(self.root.intersect_ray(&ray) < ray.tmax) {
            return;
        }
        if let Some((first, count)) = self.root_leaf {
            if count > 0 {
                leaf(first, count, &mut ray);
            }
            return;
        }
        let (o, inv) = (ray.origin, ray.inv_direction);
        let (ox, oy, oz) = (glam::Vec4::splat(o.x), glam::Vec4::splat(o.y), glam::Vec4::splat(o.z));
        let (ix, iy, iz) = (glam::Vec4::splat(inv.x), glam::Vec4::splat(inv.y), glam::Vec4::splat(inv.z));
        let mut current = 0u32;
        loop {
            // SAFETY: `current` is 0 (the root is inner here, so `new` pushed pair 0) or an
            // index `new` stored for an inner child after pushing that pair.
            let pair = unsafe { self.pairs.get_unchecked(current as usize) };
            // Lanes: (t at min, t at max) of the left and right child along each axis, then
            // each child's near and far t, as `Aabb::intersect_ray` computes them.
            let tx = (pair.x - ox) * ix;
            let ty = (pair.y - oy) * iy;
            let tz = (pair.z - oz) * iz;
            let (sx, sy, sz) = (tx.zwxy(), ty.zwxy(), tz.zwxy());
            let near = tx.min(sx).max(ty.min(sy).max(tz.min(sz)));
            let far = tx.max(sx).min(ty.max(sy).min(tz.max(sz)));
            let crossed = far.cmpge(near) & far.cmpge(glam::Vec4::ZERO);
            let t = glam::Vec4::select(crossed, near, glam::Vec4::INFINITY);
            let (mut lt, mut rt) = (t.x, t.y);
            let (mut l, mut r) = (0usize, 1usize);
            if lt > rt {
                std::mem::swap(&mut lt, &mut rt);
                std::mem::swap(&mut l, &mut r);
            }
            // Whether to go down child `k` (entry `t`, against the ray's tmax as it is then): a
            // leaf is handed to `leaf` at once instead. None: `leaf` said stop.
            let mut go = |k: usize, t: f32, ray: &mut Ray| -> Option<bool> {
                let hit = t < ray.tmax;
                if hit && pair.count[k] != 0 {
                    return leaf(pair.index[k], pair.count[k], ray).then_some(false);
                }
                Some(hit)
            };
            let Some(go_left) = go(l, lt, &mut ray) else { return };
            let Some(go_right) = go(r, rt, &mut ray) else { return };
            match next_pair(stack, go_left.then_some(pair.index[l]), go_right.then_some(pair.index[r])) {
                Some(next) => current = next,
                None => return,
            }
        }
    }
}

impl Pairs {
    /// `traverse` for a packet of four rays: `o` and `inv` hold the rays'
    /// origins and inverse directions per axis (one lane a ray), `tmax` each ray's current
    /// limit (-inf: the lane takes no part). Each pair's boxes are tested for all four rays at
    /// once, by the same operations per lane as `traverse_on` (so a lane enters exactly the
    /// boxes its ray alone would at that `tmax`); `leaf(first, count, lanes, tmax)` is called
    /// for each leaf with the bits of the lanes that reach it, and may lower their `tmax`. The
    /// nearer child is walked first by its nearest lane. Neighbouring pixels' rays walk mostly
    /// the same nodes, so one walk serves four: 1M primary rays on the 1M-triangle mesh took
    /// 0.69x the time of single rays, with the same hits. `self.depth` must be at most
    /// `INLINE_STACK`.
    #[inline(always)]
    pub(super) fn traverse4<F: FnMut(u32, u32, u32, &mut Vec4)>(
        &self,
        o: [Vec4; 3],
        inv: [Vec4; 3],
        rays: &[Ray; 4],
        tmax: &mut Vec4,
        mut leaf: F,
    ) {
        debug_assert!(self.depth <= INLINE_STACK);
        let mut root = 0u32;
        for (l, ray) in rays.iter().enumerate() {
            if self.root.intersect_ray(ray) < tmax[l] {
                root |= 1 << l;
            }
        }
        if root == 0 {
            return;
        }
        if let Some((first, count)) = self.root_leaf {
            if count > 0 {
                leaf(first, count, root, tmax);
            }
            return;
        }
        // One child's entry distance per lane (infinite: missed), as `traverse_on` computes
        // it for one ray: the same subtractions, products, minima and maxima in the same order.
        let entry = |min: [f32; 3], max: [f32; 3]| -> Vec4 {
            let (ax, bx) = ((Vec4::splat(min[0]) - o[0]) * inv[0], (Vec4::splat(max[0]) - o[0]) * inv[0]);
            let (ay, by) = ((Vec4::splat(min[1]) - o[1]) * inv[1], (Vec4::splat(max[1]) - o[1]) * inv[1]);
            let (az, bz) = ((Vec4::splat(min[2]) - o[2]) * inv[2], (Vec4::splat(max[2]) - o[2]) * inv[2]);
            let near = ax.min(bx).max(ay.min(by).max(az.min(bz)));
            let far = ax.max(bx).min(ay.max(by).min(az.max(bz)));
            let crossed = far.cmpge(near) & far.cmpge(Vec4::ZERO);
            Vec4::select(crossed, near, Vec4::INFINITY)
        };
        let mut stack = InlineStack::new();
        let mut current = 0u32;
        loop {
            // SAFETY: as in `traverse_on`.
            let pair = unsafe { self.pairs.get_unchecked(current as usize) };
            let (x, y, z) = (pair.x, pair.y, pair.z);
            let mut t = [entry([x.x, y.x, z.x], [x.z, y.z, z.z]), entry([x.y, y.y, z.y], [x.w, y.w, z.w])];
            let (mut l, mut r) = (0usize, 1usize);
            let nearest = |t: Vec4, tmax: Vec4| Vec4::select(t.cmplt(tmax), t, Vec4::INFINITY).min_element();
            if nearest(t[0], *tmax) > nearest(t[1], *tmax) {
                (l, r) = (1, 0);
                t.swap(0, 1);
            }
            // Lanes going down child `k` (entry `t`, against the lanes' tmax as they are
            // then); a leaf is handed to `leaf` at once instead (no lane goes further).
            let mut go = |k: usize, t: Vec4, tmax: &mut Vec4| -> u32 {
                let lanes = t.cmplt(*tmax).bitmask();
                if lanes != 0 && pair.count[k] != 0 {
                    leaf(pair.index[k], pair.count[k], lanes, tmax);
                    return 0;
                }
                lanes
            };
            let go_left = go(l, t[0], tmax) != 0;
            let go_right = go(r, t[1], tmax) != 0;
            match next_pair(&mut stack, go_left.then_some(pair.index[l]), go_right.then_some(pair.index[r])) {
                Some(next) => current = next,
                None => return,
            }
        }
    }
}

impl Pair {
    pub(super) const EMPTY: Pair =
        Pair { x: glam::Vec4::ZERO, y: glam::Vec4::ZERO, z: glam::Vec4::ZERO, index: [0; 2], count: [0; 2] };
}

/// Slightly beyond distance `t`: a closest-hit walk's new limit after a hit at `t`, so nodes
/// whose entry is exactly `t` are still visited and an equal-distance triangle there can win
/// the id tie-break.
#[inline(always)]
pub(super) fn just_beyond(t: f32) -> f32 {
    t * (1.0 + 4.0 * f32::EPSILON) + f32::MIN_POSITIVE
}

/// Keeps `hit` in `best` when it is nearer, or as near with a lower triangle id (so the
/// result never depends on the order triangles are met); the walk's new limit either way.
#[inline(always)]
pub(super) fn offer(best: &mut Option<Hit>, hit: Hit) -> f32 {
    let better = match best {
        None => true,
        Some(b) => hit.t < b.t || (hit.t == b.t && hit.tri < b.tri),
    };
    if better {
        *best = Some(hit);
    }
    just_beyond(hit.t)
}

/// The pair a walk visits next, given the children of the current pair it goes down (`near`
/// first, `far` kept on `stack` for later; None: not entered): None when the walk is done.
#[inline(always)]
pub(super) fn next_pair<S: NodeStack>(stack: &mut S, near: Option<u32>, far: Option<u32>) -> Option<u32> {
    match (near, far) {
        (Some(near), Some(far)) => {
            stack.push(far);
            Some(near)
        }
        (Some(next), None) | (None, Some(next)) => Some(next),
        (None, None) => stack.pop(),
    }
}

/// The lanes of bit mask `lanes` (bit l: lane l) as a vector mask.
#[inline(always)]
pub(super) fn mask_lanes(lanes: u32) -> glam::BVec4A {
    glam::BVec4A::new(lanes & 1 != 0, lanes & 2 != 0, lanes & 4 != 0, lanes & 8 != 0)
}

/// Depth up to which the traversal stack lives on the machine stack (the trees here are about
/// 20-40 deep).
pub(super) const INLINE_STACK: usize = 64;

/// The traversal stack of pair indices.
pub(super) trait NodeStack {
    fn push(&mut self, v: u32);
    fn pop(&mut self) -> Option<u32>;
}

/// A stack on the machine stack, never zero-filled (obvhs's stacks zero-fill their slots per
/// traversal, about 1% of a render's CPU).
pub(super) struct InlineStack {
    pub(super) data: [std::mem::MaybeUninit<u32>; INLINE_STACK],
    pub(super) len: usize,
}

impl InlineStack {
    /// An empty stack, its slots left unwritten. Built as
    /// `[MaybeUninit::uninit(); INLINE_STACK]` beside `len: 0`, the whole 264-byte struct was
    /// zero-filled by a `memset` call at every traversal (two per primary ray, two per shadow
    /// ray: about 2% of a render's CPU).
    #[inline(always)]
    pub(super) fn new() -> InlineStack {
        // SAFETY: an array of `MaybeUninit` needs no initialisation.
        let data =
            unsafe { std::mem::MaybeUninit::<[std::mem::MaybeUninit<u32>; INLINE_STACK]>::uninit().assume_init() };
        InlineStack { data, len: 0 }
    }
}

impl NodeStack for InlineStack {
    #[inline(always)]
    fn push(&mut self, v: u32) {
        // At most one push per level of the tree, so `len` stays under its depth.
        self.data[self.len] = std::mem::MaybeUninit::new(v);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<u32> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: the slots below `len` were written by `push`.
        Some(unsafe { self.data[self.len].assume_init() })
    }
}

impl NodeStack for Vec<u32> {
    #[inline(always)]
    fn push(&mut self, v: u32) {
        Vec::push(self, v)
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<u32> {
        Vec::pop(self)
    }
}

/// The closest-hit traversal of `tree`: `f(ray, slot)` gives a primitive's distance
/// (infinite: missed), and the ray's `tmax` drops to each nearer one.
#[inline(always)]
pub(super) fn traverse_closest<F: FnMut(&Ray, usize) -> f32>(tree: &Pairs, ray: Ray, mut f: F) {
    tree.traverse(ray, |first, count, ray| {
        for id in first..first + count {
            let t = f(ray, id as usize);
            if t < ray.tmax {
                ray.tmax = t;
            }
        }
        true
    });
}

/// Whether no primitive of `tree` lies along the ray (stops at the first).
#[inline(always)]
pub(super) fn traverse_miss<F: FnMut(&Ray, usize) -> f32>(tree: &Pairs, ray: Ray, mut f: F) -> bool {
    let mut miss = true;
    tree.traverse(ray, |first, count, ray| {
        for id in first..first + count {
            if f(ray, id as usize) < ray.tmax {
                miss = false;
                return false;
            }
        }
        true
    });
    miss
}
