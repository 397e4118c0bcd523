//! The top level: placed objects (instances of a BLAS, or baked) and the small baked objects
//! grouped as one BLAS.

use super::*;

/// A ray in some BLAS's base space, ready for traversal and the watertight test.
#[derive(Clone, Copy)]
pub(super) struct LocalRay {
    pub(super) o: Vec3A,
    pub(super) d: Vec3A,
    pub(super) sheared: ShearedRay,
}

impl LocalRay {
    #[inline(always)]
    pub(super) fn new(o: Vec3A, d: Vec3A) -> LocalRay {
        let d = traced_direction(d);
        LocalRay { o, d, sheared: ShearedRay::new(o, d) }
    }
}

/// A placed object in the top-level BVH.
#[derive(Clone, Copy)]
pub(super) struct Instance {
    pub(super) blas: u32,
    pub(super) object: u32,
    pub(super) first_triangle: u32,
    /// Render space -> base space; None: the identity (the geometry is baked for this object).
    pub(super) to_base: Option<Affine3A>,
    /// A backdrop's plane (`scene::backdrop`): rays starting behind it pass through it.
    pub(super) backdrop: Option<Backdrop>,
    /// An enclosure (`scene::enclosure`) has its inner side only: 1 or -1, the sign of d . n
    /// (d the ray in base space, n the normal its triangles' winding gives there) of the faces
    /// a ray leaves it through, which it hits; a ray entering through a face passes it. A sweep
    /// modelled in one layer (`scene::sweep`) has its subject's side only, the same way. 0 for
    /// every other object.
    pub(super) cull: f32,
    /// Enclosures cast no shadow (`occluded` passes them).
    pub(super) shadowless: bool,
}

impl Instance {
    /// Whether a ray starting at `origin` (render space) passes through this instance: a
    /// backdrop has the subject's side only.
    #[inline(always)]
    pub(super) fn skipped_from(&self, origin: Vec3A) -> bool {
        self.backdrop.is_some_and(|b| b.behind(Vec3::from(origin)))
    }

    /// What its BLAS's hits are reported as.
    #[inline(always)]
    pub(super) fn owner(&self) -> Owner {
        Owner { first_triangle: self.first_triangle, object: self.object, cull: self.cull }
    }

    /// The render-space ray `world` in this instance's base space.
    #[inline(always)]
    pub(super) fn ray(&self, world: &LocalRay) -> LocalRay {
        match &self.to_base {
            None => *world,
            Some(m) => LocalRay::new(m.transform_point3a(world.o), m.transform_vector3a(world.d)),
        }
    }
}

/// The objects whose geometry is baked for them (no placement), up to `GROUP_CAP` triangles
/// in all, traced as one BLAS over their render-space triangles: a
/// ray through a table of a dozen small objects entered each object's box and walked each
/// BLAS in turn; one tree over them all splits space across objects. The still life's
/// primary rays took 0.67x the time, with the same hits. Every BLAS of a geometry is kept
/// too, so an object that moves or changes leaves the group (it is rebuilt, which the cap
/// keeps to milliseconds) and is traced through its own BLAS, as before.
pub(super) struct Group {
    /// Its triangles' ids are global triangle ids (`Tri::id`), so ties resolve as before.
    pub(super) blas: Blas,
    /// (first triangle, object) of each member, ascending: the object a hit's id lies in.
    pub(super) members: Vec<(u32, u32)>,
    /// What it was built from: each member's (BLAS content key, first triangle, object).
    pub(super) key: Vec<(u128, u32, u32)>,
}

/// The most triangles the group holds: its build (about 0.65 us a triangle on two cores,
/// 40 ms at the cap) repeats every BLAS build of its members.
pub(super) const GROUP_CAP: usize = 1 << 16;
/// `Instance::blas` and `Hit::object` of the group's instance (resolved per hit).
pub(super) const GROUP: u32 = u32::MAX;

impl Group {
    /// The group of `members` (instances with no placement, in ascending first triangle),
    /// reusing `old` when it was built from the same BLASes and objects.
    pub(super) fn build(world: &World, blas: &[Blas], members: &[Instance], old: Option<Group>) -> Option<Group> {
        let key: Vec<(u128, u32, u32)> =
            members.iter().map(|m| (blas[m.blas as usize].key, m.first_triangle, m.object)).collect();
        if let Some(old) = old.filter(|g| g.key == key) {
            return Some(old);
        }
        // The members' geometries in one, then each triangle's id made global.
        let mut merged = Geometry {
            source: 0,
            base: glam::DMat4::IDENTITY,
            positions: Vec::new(),
            normals: Vec::new(),
            uvs: None,
            colors: None,
            triangles: Vec::new(),
        };
        let mut starts = Vec::with_capacity(members.len());
        for m in members {
            let g = &world.geometries[world.objects[m.object as usize].geometry];
            let offset = merged.positions.len() as u32;
            starts.push((merged.triangles.len() as u32, m.first_triangle));
            merged.positions.extend_from_slice(&g.positions);
            merged.triangles.extend(g.triangles.iter().map(|t| t.map(|i| i + offset)));
        }
        let mut group = Blas::build(&merged, 0)?;
        for t in &mut group.tris {
            let (start, first) = starts[starts.partition_point(|s| s.0 <= t.id) - 1];
            t.id = first + (t.id - start);
        }
        let members = members.iter().map(|m| (m.first_triangle, m.object)).collect();
        Some(Group { blas: group, members, key })
    }

    /// The object global triangle `tri` belongs to.
    pub(super) fn object_of(&self, tri: u32) -> u32 {
        self.members[self.members.partition_point(|m| m.0 <= tri) - 1].1
    }
}
