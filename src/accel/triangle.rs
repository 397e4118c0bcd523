//! The watertight ray/triangle test: rays sheared onto +z, triangles tested in 2D.

use super::*;

/// A ray prepared for the watertight triangle test (Woop, Benthin and Wald, "Watertight
/// Ray/Triangle Intersection", JCGT 2(1), 2013): the axis the ray is most aligned with
/// becomes z, and a shear maps the ray onto +z, so each triangle is tested in 2D.
#[derive(Clone, Copy)]
pub(super) struct ShearedRay {
    pub(super) o: Vec3A,
    /// Permuted axes (kx, ky, kz), kz the largest component of the direction.
    pub(super) k: [usize; 3],
    /// Shear constants (Sx, Sy, Sz).
    pub(super) s: [f32; 3],
}

impl ShearedRay {
    #[inline(always)]
    pub(super) fn new(o: Vec3A, d: Vec3A) -> ShearedRay {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // Keep the triangles' winding (and so the sign of the edge functions) consistent.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        ShearedRay { o, k: [kx, ky, kz], s: [d[kx] * sz, d[ky] * sz, sz] }
    }
}

/// Smallest magnitude of a direction component we trace. obvhs replaces 1/d by 1/EPSILON for
/// |d| <= f32::EPSILON (to avoid infinities), so its slab test follows a different line than
/// the ray for nearly axis-aligned directions and culls boxes the ray does cross: a ray with
/// d = (1e-7, 0, -1) fell through a floor. We trace such rays with the component set to
/// +-MIN_COMPONENT instead (the inverse is then exact), a tilt of under 5e-7 radians: a shift
/// of 1.5e-6 render units at the far side of the scene, far below a pixel. Traversal and
/// triangle test use the same direction, so they agree.
pub(super) const MIN_COMPONENT: f32 = 4.0 * f32::EPSILON;

#[inline(always)]
pub(super) fn traced_direction(d: Vec3A) -> Vec3A {
    let fix = |x: f32| if x.abs() < MIN_COMPONENT { MIN_COMPONENT.copysign(x) } else { x };
    Vec3A::new(fix(d.x), fix(d.y), fix(d.z))
}

/// A triangle in a BLAS's leaf order: its corners in base space (see `scene::world`) and its
/// index within its geometry. 40 bytes (corners kept unaligned: the watertight test reads
/// them once, and aligned they cost 64).
#[derive(Clone, Copy)]
pub(super) struct Tri {
    pub(super) p: [Vec3; 3],
    pub(super) id: u32,
}

/// Calls `$body` with the ray axes `$k` ([kx, ky, kz], one of the six `ShearedRay::new`
/// makes) bound as the constants `$kx, $ky, $kz`: one monomorphised copy per axis order,
/// chosen once per ray and BLAS rather than per triangle component.
macro_rules! with_axes {
    ($k:expr, |$kx:ident, $ky:ident, $kz:ident| $body:expr) => {
        match $k {
            [1, 2, 0] => {
                const $kx: usize = 1;
                const $ky: usize = 2;
                const $kz: usize = 0;
                $body
            }
            [2, 1, 0] => {
                const $kx: usize = 2;
                const $ky: usize = 1;
                const $kz: usize = 0;
                $body
            }
            [2, 0, 1] => {
                const $kx: usize = 2;
                const $ky: usize = 0;
                const $kz: usize = 1;
                $body
            }
            [0, 2, 1] => {
                const $kx: usize = 0;
                const $ky: usize = 2;
                const $kz: usize = 1;
                $body
            }
            [0, 1, 2] => {
                const $kx: usize = 0;
                const $ky: usize = 1;
                const $kz: usize = 2;
                $body
            }
            _ => {
                const $kx: usize = 1;
                const $ky: usize = 0;
                const $kz: usize = 2;
                $body
            }
        }
    };
}
pub(super) use with_axes;
impl Tri {
    /// Distance and barycentrics (u, v) of the hit within [tmin, tmax], if any. Watertight: a
    /// ray through a shared edge or vertex hits at least one of the triangles sharing it (the
    /// Moller-Trumbore test this replaces let ~3% of axis-aligned rays through a tessellated
    /// floor fall through its edges). Degenerate triangles, rays in a triangle's plane and NaN
    /// inputs never hit; both faces hit.
    #[inline(always)]
    pub(super) fn intersect(&self, r: &ShearedRay, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        with_axes!(r.k, |KX, KY, KZ| self.intersect_axes::<KX, KY, KZ>(r, tmin, tmax))
    }

    /// `intersect` with the ray's axes (kx, ky, kz) as constants: each corner's components
    /// are then fixed lanes, not a run-time index into a SIMD vector (a store and a load per
    /// component, ~20% of a primary ray's cost on venus_11k). The same operations in the
    /// same order, so the same bits.
    #[inline(always)]
    pub(super) fn intersect_axes<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        r: &ShearedRay,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        debug_assert_eq!(r.k, [KX, KY, KZ]);
        let [sx, sy, sz] = r.s;
        let a = Vec3A::from(self.p[0]) - r.o;
        let b = Vec3A::from(self.p[1]) - r.o;
        let c = Vec3A::from(self.p[2]) - r.o;
        let (a, b, c) = (lanes::<KX, KY, KZ>(a), lanes::<KX, KY, KZ>(b), lanes::<KX, KY, KZ>(c));
        let (ax, ay) = (a[0] - sx * a[2], a[1] - sy * a[2]);
        let (bx, by) = (b[0] - sx * b[2], b[1] - sy * b[2]);
        let (cx, cy) = (c[0] - sx * c[2], c[1] - sy * c[2]);
        let mut eu = cx * by - cy * bx;
        let mut ev = ax * cy - ay * cx;
        let mut ew = bx * ay - by * ax;
        // An edge function of exactly 0 may be rounding: decide it in double precision.
        if eu == 0.0 || ev == 0.0 || ew == 0.0 {
            let f = |x: f32| x as f64;
            eu = (f(cx) * f(by) - f(cy) * f(bx)) as f32;
            ev = (f(ax) * f(cy) - f(ay) * f(cx)) as f32;
            ew = (f(bx) * f(ay) - f(by) * f(ax)) as f32;
        }
        if (eu < 0.0 || ev < 0.0 || ew < 0.0) && (eu > 0.0 || ev > 0.0 || ew > 0.0) {
            return None;
        }
        let det = eu + ev + ew;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let t = (eu * (sz * a[2]) + ev * (sz * b[2]) + ew * (sz * c[2])) / det;
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        // eu weighs p0, ev p1, ew p2; the hit is (1 - u - v) p0 + u p1 + v p2.
        Some((t, ev / det, ew / det))
    }
}

/// Whose triangles a BLAS query reports hits as (`Instance::owner`): the first global
/// triangle id and the object of the instance traced, and its culling (`Instance::cull`).
#[derive(Clone, Copy)]
pub(super) struct Owner {
    pub(super) first_triangle: u32,
    pub(super) object: u32,
    pub(super) cull: f32,
}

impl Owner {
    #[inline(always)]
    pub(super) fn hit(&self, tri: &Tri, t: f32, u: f32, v: f32) -> Hit {
        Hit { tri: self.first_triangle + tri.id, object: self.object, t, u, v }
    }
}

impl Tri {
    /// Whether a hit on this triangle is refused for a ray along `d` (`Instance::cull`): the
    /// sign of d . n (n the normal its winding gives) is `cull`'s opposite. Tested only on a
    /// hit, so instances without culling (`cull` 0) pay a compare per hit.
    #[inline(always)]
    pub(super) fn culled(&self, d: Vec3A, cull: f32) -> bool {
        if cull == 0.0 {
            return false;
        }
        let [a, b, c] = self.p.map(Vec3A::from);
        cull * d.dot((b - a).cross(c - a)) < 0.0
    }
}

/// Component `K` of `v` (K a constant: a fixed lane).
#[inline(always)]
pub(super) fn lane<const K: usize>(v: Vec3A) -> f32 {
    match K {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

/// `v`'s components in the order (KX, KY, KZ).
#[inline(always)]
pub(super) fn lanes<const KX: usize, const KY: usize, const KZ: usize>(v: Vec3A) -> [f32; 3] {
    [lane::<KX>(v), lane::<KY>(v), lane::<KZ>(v)]
}

/// Whether a triangle can ever be hit: finite corners, no two equal (the watertight test's
/// determinant is exactly 0 then).
pub(super) fn hittable([a, b, c]: [Vec3; 3]) -> bool {
    a.is_finite() && b.is_finite() && c.is_finite() && a != b && b != c && a != c
}
