//! The built-in scene: a still life on a table (a guitar, a jug, a bottle, a bowl of fruit,
//! a glass, a book), the subject matter of Picasso's and Braque's analytic period.
//! Procedural, so the binary renders something with no file at hand.

use std::f32::consts::{PI, TAU};

use glam::{DMat4, DQuat, DVec3, Vec2, Vec3, Vec4};

use super::{Material, Mesh, Object, Projection, Scene, SceneCamera, compute_normals};

fn material(name: &str, r: f32, g: f32, b: f32, roughness: f32) -> Material {
    Material { name: name.into(), base_color: Vec4::new(r, g, b, 1.0), roughness, ..Material::default() }
}

/// A surface of revolution about +Y from a (radius, height) profile, `segments` around.
pub fn lathe(name: &str, profile: &[Vec2], segments: u32, material: usize) -> Mesh {
    let mut positions = Vec::new();
    for p in profile {
        for s in 0..segments {
            let a = TAU * s as f32 / segments as f32;
            positions.push(Vec3::new(p.x * a.cos(), p.y, -p.x * a.sin()));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..profile.len() as u32 - 1 {
        for s in 0..segments {
            let (a, b) = (i * segments + s, i * segments + (s + 1) % segments);
            let (c, d) = (a + segments, b + segments);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    // Close a profile that starts (or ends) off the axis with a fan to the axis.
    for (row, outward) in [(0u32, true), (profile.len() as u32 - 1, false)] {
        let p = profile[row as usize];
        if p.x > 1e-6 {
            positions.push(Vec3::new(0.0, p.y, 0.0));
            let c = positions.len() as u32 - 1;
            for s in 0..segments {
                let (a, b) = (row * segments + s, row * segments + (s + 1) % segments);
                triangles.push(if outward { [c, b, a] } else { [c, a, b] });
            }
        }
    }
    let normals = compute_normals(&positions, &triangles);
    Mesh { name: name.into(), positions, normals, uvs: None, colors: None, triangles, material: Some(material) }
}

/// A UV sphere of the given radii (an ellipsoid), centred at the origin.
pub fn ellipsoid(name: &str, radii: Vec3, rings: u32, segments: u32, material: usize) -> Mesh {
    let profile: Vec<Vec2> = (0..=rings)
        .map(|i| {
            let t = PI * i as f32 / rings as f32;
            Vec2::new(t.sin(), -t.cos())
        })
        .collect();
    let mut m = lathe(name, &profile, segments, material);
    for p in &mut m.positions {
        *p *= radii;
    }
    m.normals = compute_normals(&m.positions, &m.triangles);
    m
}

/// An icosphere: the icosahedron subdivided `levels` times (20 x 4^levels faces), every
/// vertex at `radius` from the origin. Level 3 is the thesis's 1280-face sphere; with no
/// curvature variation its mesh saliency is 0 everywhere, which makes it a shared test shape.
pub fn icosphere(name: &str, levels: u32, radius: f32, material: usize) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    #[rustfmt::skip]
    let corners = [
        [-1.0, t, 0.0], [1.0, t, 0.0], [-1.0, -t, 0.0], [1.0, -t, 0.0],
        [0.0, -1.0, t], [0.0, 1.0, t], [0.0, -1.0, -t], [0.0, 1.0, -t],
        [t, 0.0, -1.0], [t, 0.0, 1.0], [-t, 0.0, -1.0], [-t, 0.0, 1.0],
    ];
    let mut positions: Vec<Vec3> = corners.iter().map(|v| Vec3::from(*v).normalize()).collect();
    #[rustfmt::skip]
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
        [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
        [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..levels {
        // Each edge's midpoint is made once and shared by the two triangles beside it.
        let mut midpoints = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                (p.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    let normals = positions.clone();
    for p in &mut positions {
        *p *= radius;
    }
    Mesh { name: name.into(), positions, normals, uvs: None, colors: None, triangles, material: Some(material) }
}

/// An axis-aligned box centred at the origin, flat-shaded (4 vertices per face).
pub fn cuboid(name: &str, size: Vec3, material: usize) -> Mesh {
    let h = size * 0.5;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::from_array(std::array::from_fn(|k| if k == axis { sign } else { 0.0 }));
            let (u, v) = (
                Vec3::from_array(std::array::from_fn(|k| if k == (axis + 1) % 3 { 1.0 } else { 0.0 })),
                Vec3::from_array(std::array::from_fn(|k| if k == (axis + 2) % 3 { 1.0 } else { 0.0 })),
            );
            let base = positions.len() as u32;
            for (a, b) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push((n + u * a + v * b) * h);
                normals.push(n);
            }
            let quad = if sign > 0.0 { [[0, 1, 2], [0, 2, 3]] } else { [[0, 2, 1], [0, 3, 2]] };
            for t in quad {
                triangles.push(t.map(|i| base + i));
            }
        }
    }
    Mesh { name: name.into(), positions, normals, uvs: None, colors: None, triangles, material: Some(material) }
}

/// A prism: a star-shaped outline in the XY plane extruded along Z by `depth`.
pub fn extrude(name: &str, outline: &[Vec2], depth: f32, material: usize) -> Mesh {
    let n = outline.len() as u32;
    let centre = outline.iter().copied().sum::<Vec2>() / n as f32;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for z in [depth * 0.5, -depth * 0.5] {
        positions.push(centre.extend(z));
        positions.extend(outline.iter().map(|p| p.extend(z)));
    }
    let back = n + 1;
    for i in 0..n {
        let (a, b) = (1 + i, 1 + (i + 1) % n);
        triangles.push([0, a, b]);
        triangles.push([back, back + b, back + a]);
    }
    // Sides get their own vertices so the rim is sharp.
    let side0 = positions.len() as u32;
    for i in 0..n {
        let (p, q) = (outline[i as usize], outline[((i + 1) % n) as usize]);
        positions.extend([
            p.extend(depth * 0.5),
            q.extend(depth * 0.5),
            q.extend(-depth * 0.5),
            p.extend(-depth * 0.5),
        ]);
        let b = side0 + 4 * i;
        triangles.push([b, b + 3, b + 2]);
        triangles.push([b, b + 2, b + 1]);
    }
    let mut normals = compute_normals(&positions[..side0 as usize], &triangles[..2 * n as usize]);
    let side_normals = compute_normals(&positions, &triangles);
    normals.extend_from_slice(&side_normals[side0 as usize..]);
    Mesh { name: name.into(), positions, normals, uvs: None, colors: None, triangles, material: Some(material) }
}

/// A guitar body outline: two lobes joined at a waist, star-shaped from its centroid.
fn guitar_outline() -> Vec<Vec2> {
    (0..96)
        .map(|i| {
            let (s, c) = (TAU * i as f32 / 96.0).sin_cos();
            // Lower bout wider than the upper one, a waist just above the middle.
            let width = 0.27 - 0.04 * s - 0.07 * (-((s - 0.1) / 0.25).powi(2)).exp();
            Vec2::new(width * c, 0.42 * s)
        })
        .collect()
}

fn place(mesh: usize, name: &str, t: DVec3, rot: DQuat) -> Object {
    Object { name: name.into(), mesh, transform: DMat4::from_rotation_translation(rot, t) }
}

/// The still life. Units are metres, +Y up, the table top at y = 0.
pub fn still_life() -> Scene {
    let mut s = Scene { source: "<default scene>".into(), ..Scene::default() };
    let mats = [
        material("table", 0.30, 0.17, 0.08, 0.7),
        material("ochre glaze", 0.72, 0.50, 0.20, 0.35),
        material("bottle glass", 0.10, 0.24, 0.12, 0.15),
        material("white bowl", 0.80, 0.76, 0.66, 0.4),
        material("orange", 0.85, 0.35, 0.05, 0.5),
        material("apple", 0.55, 0.08, 0.05, 0.4),
        material("lemon", 0.85, 0.70, 0.12, 0.5),
        material("glass", 0.55, 0.60, 0.62, 0.1),
        material("book", 0.38, 0.10, 0.07, 0.8),
        material("guitar wood", 0.62, 0.38, 0.16, 0.45),
        material("sound hole", 0.03, 0.02, 0.02, 0.9),
        material("neck", 0.18, 0.10, 0.05, 0.6),
    ];
    s.materials.extend(mats);
    let v = Vec2::new;
    let add = |mesh: Mesh, t: DVec3, rot: DQuat, s: &mut Scene| {
        let name = mesh.name.clone();
        s.meshes.push(mesh);
        let i = s.meshes.len() - 1;
        s.objects.push(place(i, &name, t, rot));
    };
    let id = DQuat::IDENTITY;
    add(cuboid("table", Vec3::new(2.6, 0.08, 1.5), 0), DVec3::new(0.0, -0.04, 0.0), id, &mut s);
    let jug = [
        v(0.0, 0.0),
        v(0.15, 0.0),
        v(0.19, 0.06),
        v(0.22, 0.2),
        v(0.21, 0.32),
        v(0.15, 0.45),
        v(0.09, 0.55),
        v(0.085, 0.62),
        v(0.12, 0.7),
    ];
    add(lathe("jug", &jug, 40, 1), DVec3::new(-0.6, 0.0, -0.2), id, &mut s);
    let bottle = [
        v(0.0, 0.0),
        v(0.11, 0.0),
        v(0.115, 0.02),
        v(0.115, 0.52),
        v(0.09, 0.62),
        v(0.04, 0.7),
        v(0.035, 0.88),
        v(0.045, 0.9),
        v(0.0, 0.9),
    ];
    add(lathe("bottle", &bottle, 36, 2), DVec3::new(-0.05, 0.0, -0.42), id, &mut s);
    let bowl = [
        v(0.0, 0.0),
        v(0.12, 0.0),
        v(0.2, 0.04),
        v(0.28, 0.12),
        v(0.32, 0.17),
        v(0.31, 0.175),
        v(0.27, 0.13),
        v(0.19, 0.06),
        v(0.0, 0.04),
    ];
    add(lathe("bowl", &bowl, 48, 3), DVec3::new(0.45, 0.0, 0.18), id, &mut s);
    add(ellipsoid("orange", Vec3::splat(0.09), 16, 24, 4), DVec3::new(0.37, 0.13, 0.15), id, &mut s);
    add(ellipsoid("apple", Vec3::new(0.085, 0.075, 0.085), 16, 24, 5), DVec3::new(0.53, 0.12, 0.24), id, &mut s);
    add(
        ellipsoid("lemon", Vec3::new(0.1, 0.065, 0.065), 16, 24, 6),
        DVec3::new(0.5, 0.16, 0.06),
        DQuat::from_rotation_y(0.5),
        &mut s,
    );
    let glass = [
        v(0.0, 0.0),
        v(0.07, 0.0),
        v(0.07, 0.01),
        v(0.012, 0.02),
        v(0.012, 0.14),
        v(0.05, 0.17),
        v(0.075, 0.25),
        v(0.07, 0.33),
        v(0.065, 0.33),
        v(0.068, 0.25),
        v(0.0, 0.16),
    ];
    add(lathe("glass", &glass, 32, 7), DVec3::new(-0.2, 0.0, 0.35), id, &mut s);
    add(
        cuboid("book", Vec3::new(0.42, 0.07, 0.3), 8),
        DVec3::new(-0.7, 0.035, 0.35),
        DQuat::from_rotation_y(0.35),
        &mut s,
    );
    // The guitar leans back against the bottle's side, body on the table.
    let tilt = DQuat::from_rotation_y(-0.45) * DQuat::from_rotation_x(-0.35);
    let body_centre = DVec3::new(0.55, 0.43, -0.35);
    add(extrude("guitar body", &guitar_outline(), 0.09, 9), body_centre, tilt, &mut s);
    let hole = ellipsoid("sound hole", Vec3::new(0.075, 0.075, 0.004), 4, 24, 10);
    let hole_offset = tilt * DVec3::new(0.0, 0.1, 0.047);
    add(hole, body_centre + hole_offset, tilt, &mut s);
    let neck_offset = tilt * DVec3::new(0.0, 0.72, 0.02);
    add(cuboid("neck", Vec3::new(0.07, 0.62, 0.05), 11), body_centre + neck_offset, tilt, &mut s);
    // The focal centre sits just behind the guitar, so the spherical camera wraps the
    // objects: the bottle and jug are seen from both flanks at once.
    let eye = DVec3::new(0.0, 1.25, 2.4);
    s.camera = Some(SceneCamera {
        position: eye,
        forward: (DVec3::new(0.0, 0.3, 0.0) - eye).normalize(),
        up: DVec3::Y,
        projection: Projection::Perspective { yfov: 40f64.to_radians() },
        focus_distance: Some(3.6),
    });
    if let Some(c) = s.camera.as_mut() {
        c.up = (c.up - c.forward * c.up.dot(c.forward)).normalize();
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn still_life_is_well_formed() {
        let s = still_life();
        assert!(s.triangle_count() > 5000);
        for m in &s.meshes {
            assert!(m.positions.iter().all(|p| p.is_finite()), "{}", m.name);
            assert_eq!(m.normals.len(), m.positions.len());
            for t in &m.triangles {
                assert!(t.iter().all(|&i| (i as usize) < m.positions.len()), "{}", m.name);
            }
        }
    }

    #[test]
    fn lathe_normals_point_outwards() {
        let m = ellipsoid("s", Vec3::ONE, 12, 16, 0);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            if p.length() > 0.5 {
                assert!(p.dot(*n) > 0.0, "inward normal at {p:?}");
            }
        }
    }
}
