"""Build the look-judging scenes: small glTF scenes of subjects the renderer was not tuned on.

Usage: python make-look-scenes.py OUT_DIR [NAME...]   (bpy 5.0.1 importable)
Without NAMEs it builds the first set; NAMEs pick scenes from any set, `second` stands for the
whole second set, `rooms` for the rooms and `sweeps` for the subjects on a studio sweep.

Why: the look of cubist is tuned on a handful of models (a still life, a bunny, a teapot, a
cow, a bust of Venus...). Judging a look on those alone rewards over-fitting. These scenes are
fresh subjects for blind judging (guitar and still-life take up subjects of the built-in still
life, with new shapes and layouts): a judge who has never seen them is shown a render and must be
able to name the subject, so each is built plainly enough to be recognised from a plain
(non-cubist) render, from primitives (spheres, cylinders, boxes, lathed profiles, swept tubes)
with plain base colours and no textures. Each subject stands about the origin, its base at
height 0, scaled so its largest side is 1.6 units; every scene is y-up except `zup-figure`.

Scenes (file name: subject, and what it tests):
  head-bust        a head and neck on a plinth: eye sockets, nose wedge, brow, lips, ears
                   (a face: the small features a viewer looks at first)
  figure-standing  a standing person, arms down and slightly bent (a whole human figure)
  figure-seated    a person seated on a stool, hands on knees (folded limbs, two objects)
  horse            a horse side-on: body, neck, head with muzzle and ears, legs, tail, mane
  bird             a small bird (robin-like) perched on a branch: beak, folded wings, tail
  hammer           a claw hammer, upright: handle with grip, head with face and split claw
  wrench           an adjustable wrench: handle with hang hole, open jaw, worm screw
  chair            a wooden chair with a slatted back, turned three-quarters
  guitar           an acoustic guitar: waisted body (two merged ellipses), sound hole,
                   bridge, neck with frets, head with six pegs, strings
  still-life       on a table top: a bottle, a cup, a bowl of three fruit, a knife
  room             a corner of a room (floor, two walls) with a table, a chair and a floor
                   lamp, with a camera looking in (tests the scene's own camera)
  teakettle        a kettle: round body, spout, arched handle, lid with knob
  bicycle          a bicycle side-on: spoked wheels, diamond frame, handlebar, saddle, cranks
  zup-figure       figure-standing exported z-up (tests orientation handling)

Second set: ten more subjects, kept unseen for a later round of blind judging (build them
apart, e.g. `make-look-scenes.py OUT2 second`, and keep their renders away from tuning):
  violin                 body with lower and upper bouts, C-bouts and corners, arched plates,
                         f-holes, bridge, tailpiece, fingerboard, pegbox with pegs, scroll, strings
  mandolin               bowl back (deep rounded staves), flat top with round sound hole,
                         pickguard, bridge, neck with frets, head with eight tuners, strings
  wine-bottle-and-glass  a labelled wine bottle and a stemmed glass of red wine side by side on
                         a small round pedestal table (two objects and their support)
  table-lamp             round base, turned ceramic body, stem, bulb, conical shade on a harp,
                         cord (an open shade: inside and outside surfaces)
  scissors               two blades crossed at a pivot screw, slightly open, two finger rings
  cat                    a cat sitting, facing the viewer: ears, eyes, muzzle, whiskers, forelegs,
                         haunches, tail wrapped round to the front paws
  armchair               a padded armchair: seat and back cushions, rolled armrests, short legs
  vase-of-flowers        a vase with five flowers of different colours on stems, a leaf on each
  pipe                   a tobacco pipe lying side-on: bowl with tobacco, shank, band, bent stem,
                         bit (a small subject with one long thin part)
  trumpet                bell, three valves with buttons, tubing loops (bell bend, main tuning
                         slide, valve slides), leadpipe and mouthpiece

Rooms: three rooms built of separate slabs (floor and walls), for the framing of open rooms:
  lounge                 a sofa, a low table with a bowl of fruit, a potted plant, a picture;
                         three walls 15 cm thick, the camera inside
  kitchen                a table with a bottle and a jug, two chairs, a shelf of plates; a
                         floor and one wall
  attic                  a person seated on a stool in an attic with a window; walls 25 cm thick,
                         the camera outside

Sweeps: four subjects of the first set on a studio sweep (a floor curving up into a wall, one
mesh of one layer, about four times the subject's size), as product and character shots stand
them; for the framing of sweeps:
  sweep-horse, sweep-chair           the renderer's own view
  sweep-head, sweep-teakettle        a camera of the scene's, a little above and to one side

Deterministic: the same bpy gives the same bytes on every run. Meshes are built vertex by vertex
with bmesh (no mesh operators, no bmesh.ops.create_uvsphere, whose face order varies between runs),
then exported with the stock glTF exporter. Check a scene with
`cubist render OUT_DIR/NAME.glb --preset plain --camera perspective`.
"""

import atexit
import math
import os
import shutil
import sys
import tempfile

# keep Blender's user files out of the home directory
_USER_RESOURCES = tempfile.mkdtemp(prefix="look-scenes-")
atexit.register(shutil.rmtree, _USER_RESOURCES, ignore_errors=True)
os.environ["BLENDER_USER_RESOURCES"] = _USER_RESOURCES

import bpy  # noqa: E402  (bpy first: it makes bmesh and mathutils importable)
import bmesh  # noqa: E402
from mathutils import Euler, Matrix, Vector  # noqa: E402

TARGET_SIZE = 1.6  # the largest side of every subject, in scene units

# ---------------------------------------------------------------- scene basics


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def mat(name, rgb, rough=0.6, metal=0.0):
    """A plain material by name (one per name per scene)."""
    m = bpy.data.materials.get(name)
    if m is None:
        m = bpy.data.materials.new(name)
        m.use_nodes = True
        bsdf = m.node_tree.nodes.get("Principled BSDF")
        bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
        bsdf.inputs["Roughness"].default_value = rough
        bsdf.inputs["Metallic"].default_value = metal
        m.diffuse_color = (*rgb, 1.0)
    return m


def link(name, bm, material, smooth=True, sharp_deg=None, subsurf=0):
    """Make an object from a bmesh whose vertices are already in world coordinates."""
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    me.materials.append(material)
    if smooth:
        me.shade_smooth()
        if sharp_deg is not None:
            me.set_sharp_from_angle(angle=math.radians(sharp_deg))
    else:
        me.shade_flat()
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    if subsurf:
        mod = ob.modifiers.new("subsurf", "SUBSURF")
        mod.levels = subsurf
        mod.render_levels = subsurf
    return ob


def trs(loc=(0, 0, 0), rot=(0, 0, 0), scale=(1, 1, 1)):
    """Translation @ rotation (XYZ euler, degrees) @ scale."""
    r = Euler([math.radians(a) for a in rot], "XYZ").to_matrix().to_4x4()
    return Matrix.Translation(Vector(loc)) @ r @ Matrix.Diagonal((*scale, 1.0))


def along(a, b):
    """Matrix placing a unit-length z-axis item from a to b (centre at the midpoint)."""
    a, b = Vector(a), Vector(b)
    d = b - a
    q = Vector((0, 0, 1)).rotation_difference(d.normalized())
    return Matrix.Translation((a + b) / 2) @ q.to_matrix().to_4x4(), d.length


# ---------------------------------------------------------------- shapes


def ellipsoid(name, center, radii, material, rot=(0, 0, 0), seg=48, rings=24, subsurf=0):
    # a UV sphere made here: bmesh's create_uvsphere orders its faces differently run to run
    profile = [(math.sin(math.pi * i / rings), -math.cos(math.pi * i / rings)) for i in range(rings + 1)]
    profile[0] = (0.0, -1.0)
    profile[-1] = (0.0, 1.0)
    bm = lathe_bmesh(profile, seg)
    bm.transform(trs(center, rot, radii))
    return link(name, bm, material, subsurf=subsurf)


def cyl(name, a, b, r1, material, r2=None, seg=32, smooth=True):
    """A (possibly tapered) capped cylinder from point a to point b."""
    m, length = along(a, b)
    bm = bmesh.new()
    bmesh.ops.create_cone(
        bm, cap_ends=True, cap_tris=False, segments=seg, radius1=r1,
        radius2=r1 if r2 is None else r2, depth=length,
    )
    bm.transform(m)
    return link(name, bm, material, smooth=smooth, sharp_deg=50)


def capsule(name, a, b, r1, material, r2=None, seg=32):
    """A limb: a tapered cylinder with a sphere at each end."""
    r2 = r1 if r2 is None else r2
    cyl(name, a, b, r1, material, r2, seg)
    ellipsoid(name + ".a", a, (r1, r1, r1), material, seg=seg, rings=seg // 2)
    ellipsoid(name + ".b", b, (r2, r2, r2), material, seg=seg, rings=seg // 2)


def box(name, center, size, material, rot=(0, 0, 0), bevel=0.0, segs=4):
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bm.transform(Matrix.Diagonal((*size, 1.0)))
    if bevel > 0:
        bmesh.ops.bevel(
            bm, geom=list(bm.verts) + list(bm.edges), offset=bevel, segments=segs,
            profile=0.5, affect="EDGES",
        )
    bm.transform(trs(center, rot))
    return link(name, bm, material, smooth=bevel > 0, sharp_deg=40)


def from_pydata(name, verts, faces, material, smooth=False, sharp_deg=None, subsurf=0):
    bm = bmesh.new()
    vs = [bm.verts.new(v) for v in verts]
    for f in faces:
        bm.faces.new([vs[i] for i in f])
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces[:])
    return link(name, bm, material, smooth=smooth, sharp_deg=sharp_deg, subsurf=subsurf)


def lathe_bmesh(profile, seg, center=(0, 0, 0), scale=(1, 1)):
    """Revolve a profile of (radius, height) points about the z axis; radius 0 makes a pole."""
    bm = bmesh.new()
    cx, cy, cz = center
    rings = []
    for r, z in profile:
        if r < 1e-9:
            rings.append([bm.verts.new((cx, cy, cz + z))])
        else:
            rings.append([
                bm.verts.new((cx + r * math.cos(2 * math.pi * i / seg) * scale[0],
                              cy + r * math.sin(2 * math.pi * i / seg) * scale[1], cz + z))
                for i in range(seg)
            ])
    for ra, rb in zip(rings, rings[1:]):
        if len(ra) == 1 and len(rb) == 1:
            continue
        for i in range(seg):
            j = (i + 1) % seg
            if len(ra) == 1:
                bm.faces.new((ra[0], rb[i], rb[j]))
            elif len(rb) == 1:
                bm.faces.new((ra[i], ra[j], rb[0]))
            else:
                bm.faces.new((ra[i], ra[j], rb[j], rb[i]))
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces[:])
    return bm


def lathe(name, profile, material, center=(0, 0, 0), seg=64, sharp_deg=35, scale=(1, 1, 1)):
    """A lathed (turned) object: see lathe_bmesh."""
    return link(name, lathe_bmesh(profile, seg, center, scale[:2]), material, smooth=True, sharp_deg=sharp_deg)


def tube(name, points, radii, material, seg=20, caps=True):
    """Sweep a circle along a polyline (radius per point), frames by parallel transport."""
    pts = [Vector(p) for p in points]
    if not isinstance(radii, (list, tuple)):
        radii = [radii] * len(pts)
    tangents = []
    for i in range(len(pts)):
        a = pts[max(i - 1, 0)]
        b = pts[min(i + 1, len(pts) - 1)]
        tangents.append((b - a).normalized())
    t0 = tangents[0]
    n = t0.cross(Vector((0, 0, 1)) if abs(t0.z) < 0.9 else Vector((1, 0, 0))).normalized()
    bm = bmesh.new()
    rings = []
    for p, t, r in zip(pts, tangents, radii):
        n = (n - t * n.dot(t)).normalized()
        bvec = t.cross(n)
        ring = []
        for k in range(seg):
            a = 2 * math.pi * k / seg
            ring.append(bm.verts.new(p + r * (math.cos(a) * n + math.sin(a) * bvec)))
        rings.append(ring)
    for ra, rb in zip(rings, rings[1:]):
        for k in range(seg):
            bm.faces.new((ra[k], ra[(k + 1) % seg], rb[(k + 1) % seg], rb[k]))
    if caps:
        bm.faces.new(rings[0][::-1])
        bm.faces.new(rings[-1])
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces[:])
    return link(name, bm, material, smooth=True, sharp_deg=60)


def arc_points(center, radius, a0, a1, n, plane="xz"):
    """Points on a circular arc (degrees) in the given plane."""
    cx, cy, cz = center
    out = []
    for i in range(n + 1):
        a = math.radians(a0 + (a1 - a0) * i / n)
        u, v = radius * math.cos(a), radius * math.sin(a)
        if plane == "xz":
            out.append((cx + u, cy, cz + v))
        elif plane == "yz":
            out.append((cx, cy + u, cz + v))
        else:
            out.append((cx + u, cy + v, cz))
    return out


def torus(name, center, major, minor, material, rot=(0, 0, 0), seg=48, minor_seg=12):
    pts = arc_points((0, 0, 0), major, 0, 360, seg, plane="xy")[:-1]
    pts.append(pts[0])
    ob = tube(name, pts, minor, material, seg=minor_seg, caps=False)
    ob.data.transform(trs(center, rot))
    return ob


def cut(ob, cutter, operation="DIFFERENCE"):
    """Boolean the cutter out of ob now (exact solver), then delete the cutter."""
    mod = ob.modifiers.new("cut", "BOOLEAN")
    mod.operation = operation
    mod.solver = "EXACT"
    mod.object = cutter
    bake(ob)
    bpy.data.objects.remove(cutter)
    # the cut leaves long thin faces: keep its flat parts flat-shaded
    ob.data.set_sharp_from_angle(angle=math.radians(30))


def bake(ob):
    """Replace an object's mesh by its evaluated mesh (modifiers applied)."""
    dg = bpy.context.evaluated_depsgraph_get()
    me = bpy.data.meshes.new_from_object(ob.evaluated_get(dg))
    ob.modifiers.clear()
    ob.data = me


# ---------------------------------------------------------------- export


def normalise(rot_z=0.0):
    """Bake modifiers, turn the subject about z, centre it in x/y, base at 0, largest side TARGET_SIZE."""
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    for o in meshes:
        if o.modifiers:
            bake(o)
    bpy.context.view_layer.update()  # fresh matrix_world for the camera
    turn = Matrix.Rotation(math.radians(rot_z), 4, "Z")
    lo = Vector((1e9,) * 3)
    hi = Vector((-1e9,) * 3)
    for o in meshes:
        o.data.transform(turn)
        for v in o.data.vertices:
            lo = Vector(map(min, lo, v.co))
            hi = Vector(map(max, hi, v.co))
    s = TARGET_SIZE / max(hi - lo)
    shift = Vector(((lo.x + hi.x) / 2, (lo.y + hi.y) / 2, lo.z))
    m = Matrix.Diagonal((s, s, s, 1.0)) @ Matrix.Translation(-shift)
    for o in meshes:
        o.data.transform(m)
        o.data.update()
    for o in bpy.context.scene.objects:
        if o.type != "MESH":
            o.matrix_world = m @ turn @ o.matrix_world
            o.scale = (1, 1, 1)


def export(path, yup=True):
    bpy.ops.export_scene.gltf(
        filepath=path, export_format="GLB", export_apply=True, export_yup=yup,
        export_cameras=True, export_lights=True, export_animations=False,
    )


# ---------------------------------------------------------------- subjects


def skin():
    return mat("skin", (0.80, 0.58, 0.46), rough=0.5)


def build_head_bust():
    stone = mat("stone", (0.55, 0.52, 0.48))
    sk = skin()
    box("plinth", (0, 0, 0.09), (0.5, 0.42, 0.18), stone, bevel=0.01)
    box("plinth.top", (0, 0, 0.2), (0.42, 0.34, 0.04), stone, bevel=0.006)
    ellipsoid("shoulders", (0, 0.01, 0.25), (0.25, 0.13, 0.14), sk, seg=48, rings=24, subsurf=1)
    cyl("neck", (0, 0.01, 0.28), (0, 0.005, 0.56), 0.085, sk, r2=0.075, seg=24)
    head = ellipsoid("head", (0, 0, 0.7), (0.16, 0.19, 0.22), sk, seg=48, rings=24, subsurf=1)
    ellipsoid("jaw", (0, -0.06, 0.59), (0.11, 0.12, 0.09), sk, seg=48, rings=24, subsurf=1)
    for sx in (-1, 1):
        sock = ellipsoid("socket", (sx * 0.062, -0.178, 0.695), (0.036, 0.03, 0.024), sk)
        cut(head, sock)
    eye_w = mat("eye", (0.92, 0.9, 0.86), rough=0.3)
    iris = mat("iris", (0.18, 0.12, 0.08), rough=0.3)
    for sx in (-1, 1):
        ellipsoid(f"eye{sx}", (sx * 0.062, -0.165, 0.695), (0.024, 0.024, 0.02), eye_w)
        ellipsoid(f"iris{sx}", (sx * 0.062, -0.186, 0.695), (0.009, 0.004, 0.009), iris)
        # brow ridge over each eye
        ellipsoid(f"brow{sx}", (sx * 0.062, -0.178, 0.728), (0.042, 0.016, 0.011), sk, rot=(0, sx * -8, 0))
        # ear
        ellipsoid(f"ear{sx}", (sx * 0.158, 0.01, 0.69), (0.02, 0.042, 0.06), sk, rot=(0, 0, sx * -15))
    nose = [
        (0, -0.182, 0.715), (-0.028, -0.178, 0.622), (0.028, -0.178, 0.622),
        (0, -0.232, 0.628), (0, -0.15, 0.66),
    ]
    from_pydata("nose", nose, [(0, 3, 1), (0, 2, 3), (1, 3, 2), (0, 1, 4), (0, 4, 2), (1, 2, 4)], sk)
    lip = mat("lip", (0.72, 0.38, 0.36), rough=0.5)
    ellipsoid("lip.upper", (0, -0.176, 0.592), (0.044, 0.016, 0.011), lip)
    ellipsoid("lip.lower", (0, -0.172, 0.574), (0.038, 0.017, 0.012), lip)
    hair = mat("hair", (0.25, 0.16, 0.1))
    hcap = ellipsoid("hair", (0, 0.025, 0.75), (0.168, 0.19, 0.19), hair, seg=48, rings=24)
    fore = box("hair.cut", (0, -0.2, 0.66), (0.5, 0.26, 0.3), hair)
    cut(hcap, fore)
    normalise(rot_z=-20)


def build_figure(seated=False):
    sk = skin()
    shirt = mat("shirt", (0.2, 0.35, 0.6))
    trousers = mat("trousers", (0.22, 0.22, 0.26))
    shoe = mat("shoe", (0.12, 0.08, 0.06))
    hair = mat("hair", (0.25, 0.16, 0.1))
    if seated:
        wood = mat("wood", (0.55, 0.36, 0.2))
        lathe("stool.seat", [(0, 0.47), (0.2, 0.47), (0.2, 0.51), (0, 0.51)], wood)
        for k in range(3):
            a = math.radians(90 + 120 * k)
            cyl(f"stool.leg{k}", (0.12 * math.cos(a), 0.12 * math.sin(a), 0.47),
                (0.2 * math.cos(a), 0.2 * math.sin(a), 0), 0.018, wood, seg=10)
        torus("stool.ring", (0, 0, 0.18), 0.165, 0.01, wood)
        hip_z, lift = 0.58, -0.4  # pelvis height; torso heights shift by this
    else:
        hip_z, lift = 0.93, 0.0
    for sx in (-1, 1):
        x = sx * 0.1
        hip = (x, 0, hip_z)
        if seated:
            knee = (sx * 0.11, -0.42, 0.58)
            ankle = (sx * 0.11, -0.46, 0.1)
        else:
            knee = (sx * 0.1, -0.01, 0.5)
            ankle = (sx * 0.1, 0.0, 0.1)
        capsule(f"thigh{sx}", hip, knee, 0.075, trousers, r2=0.058)
        capsule(f"calf{sx}", knee, ankle, 0.056, trousers, r2=0.042)
        ellipsoid(f"foot{sx}", (ankle[0], ankle[1] - 0.06, 0.045), (0.05, 0.12, 0.045), shoe)
        sz = 1.44 + lift
        shoulder = (sx * 0.2, 0.0, sz)
        if seated:
            elbow = (sx * 0.23, -0.1, sz - 0.28)
            wrist = (sx * 0.15, -0.33, 0.64)
            hand_c, hand_r = (sx * 0.14, -0.4, 0.63), (0.035, 0.06, 0.03)
        else:
            elbow = (sx * 0.245, 0.03, sz - 0.29)
            wrist = (sx * 0.255, -0.05, sz - 0.55)
            hand_c, hand_r = (sx * 0.258, -0.06, sz - 0.62), (0.028, 0.045, 0.07)
        capsule(f"upperarm{sx}", shoulder, elbow, 0.052, shirt, r2=0.045)
        capsule(f"forearm{sx}", elbow, wrist, 0.043, sk, r2=0.033)
        ellipsoid(f"hand{sx}", hand_c, hand_r, sk)
    ellipsoid("pelvis", (0, 0, hip_z + 0.03), (0.18, 0.11, 0.1), trousers, seg=48, rings=24)
    ellipsoid("belly", (0, 0, 1.16 + lift), (0.165, 0.11, 0.2), shirt, seg=48, rings=24)
    ellipsoid("chest", (0, 0, 1.33 + lift), (0.2, 0.12, 0.15), shirt, seg=48, rings=24)
    cyl("neck", (0, 0, 1.42 + lift), (0, 0, 1.56 + lift), 0.05, sk)
    ellipsoid("head", (0, -0.01, 1.66 + lift), (0.09, 0.105, 0.12), sk, seg=48, rings=24)
    ellipsoid("hair", (0, 0.012, 1.7 + lift), (0.095, 0.105, 0.1), hair, seg=48, rings=24)
    ellipsoid("nose", (0, -0.11, 1.65 + lift), (0.014, 0.02, 0.025), sk)
    for sx in (-1, 1):
        ellipsoid(f"ear{sx}", (sx * 0.09, 0.0, 1.66 + lift), (0.012, 0.025, 0.035), sk)
    normalise(rot_z=-35 if seated else 0)


def build_horse():
    coat = mat("coat", (0.45, 0.27, 0.14))
    dark = mat("mane", (0.12, 0.08, 0.06))
    hoof = mat("hoof", (0.1, 0.1, 0.1))
    ellipsoid("body", (0, 0, 1.12), (0.62, 0.23, 0.26), coat, seg=40, rings=20, subsurf=1)
    ellipsoid("chest", (0.42, 0, 1.1), (0.24, 0.21, 0.24), coat, seg=48, rings=24)
    ellipsoid("rump", (-0.42, 0, 1.14), (0.26, 0.22, 0.25), coat, seg=48, rings=24)
    legs = [(0.45, "f"), (-0.45, "r")]
    for x, tag in legs:
        for sy in (-1, 1):
            y = sy * 0.12
            top, knee, fet = (x, y, 1.0), (x + (0.02 if tag == "f" else -0.06), y, 0.55), (x, y, 0.12)
            capsule(f"leg{tag}{sy}.up", top, knee, 0.085 if tag == "f" else 0.1, coat, r2=0.05)
            capsule(f"leg{tag}{sy}.low", knee, fet, 0.045, coat, r2=0.04)
            cyl(f"hoof{tag}{sy}", (fet[0] + 0.01, y, 0.0), (fet[0], y, 0.1), 0.06, hoof, r2=0.045)
    capsule("neck", (0.55, 0, 1.2), (0.82, 0, 1.66), 0.17, coat, r2=0.1)
    capsule("head", (0.84, 0, 1.7), (1.12, 0, 1.45), 0.1, coat, r2=0.07)
    ellipsoid("muzzle", (1.12, 0, 1.44), (0.07, 0.075, 0.08), coat)
    for sy in (-1, 1):
        cyl(f"ear{sy}", (0.8, sy * 0.05, 1.78), (0.77, sy * 0.06, 1.9), 0.028, coat, r2=0.005, seg=8)
        ellipsoid(f"eye{sy}", (0.92, sy * 0.085, 1.66), (0.02, 0.012, 0.018), dark)
        ellipsoid(f"nostril{sy}", (1.17, sy * 0.04, 1.42), (0.015, 0.01, 0.012), dark)
    mane = [(0.8, 0, 1.8), (0.72, 0, 1.68), (0.62, 0, 1.5), (0.52, 0, 1.35)]
    tube("mane", mane, [0.03, 0.05, 0.05, 0.03], dark)
    tail = [(-0.62, 0, 1.25), (-0.72, 0, 1.15), (-0.78, 0, 0.95), (-0.8, 0, 0.75), (-0.78, 0, 0.6)]
    tube("tail", tail, [0.04, 0.06, 0.07, 0.06, 0.02], dark)
    normalise()


def build_bird():
    bark = mat("bark", (0.35, 0.24, 0.16))
    brown = mat("feather", (0.42, 0.33, 0.24))
    wing = mat("wing", (0.3, 0.23, 0.17))
    breast = mat("breast", (0.88, 0.42, 0.14))
    beak = mat("beak", (0.2, 0.17, 0.12))
    eye = mat("eye", (0.03, 0.03, 0.03), rough=0.2)
    leg = mat("leg", (0.45, 0.32, 0.25))
    tube("branch", [(-0.75, 0, -0.02), (-0.3, 0, 0.0), (0.2, 0, 0.01), (0.7, 0, -0.03)],
         [0.045, 0.04, 0.036, 0.03], bark, seg=14)
    tube("twig", [(0.35, 0, 0.0), (0.5, 0.05, 0.12), (0.6, 0.08, 0.22)], [0.02, 0.015, 0.008], bark, seg=10)
    ellipsoid("leaf", (0.63, 0.08, 0.27), (0.05, 0.012, 0.08), mat("leaf", (0.3, 0.5, 0.2)), rot=(0, -30, 0))
    ellipsoid("body", (0, 0, 0.26), (0.2, 0.12, 0.13), brown, rot=(0, -25, 0), seg=48, rings=24)
    ellipsoid("breast", (0.08, 0, 0.24), (0.12, 0.1, 0.12), breast, rot=(0, -25, 0), seg=48, rings=24)
    ellipsoid("head", (0.17, 0, 0.42), (0.09, 0.085, 0.085), brown, seg=48, rings=24)
    ellipsoid("face", (0.2, 0, 0.4), (0.07, 0.07, 0.06), breast, seg=24, rings=12)
    cyl("beak", (0.25, 0, 0.415), (0.33, 0, 0.405), 0.022, beak, r2=0.002, seg=12)
    for sy in (-1, 1):
        ellipsoid(f"eye{sy}", (0.215, sy * 0.062, 0.44), (0.014, 0.01, 0.014), eye)
        ellipsoid(f"wing{sy}", (-0.05, sy * 0.105, 0.3), (0.18, 0.03, 0.085), wing, rot=(0, -22, 0))
        x, y = 0.0, sy * 0.04
        cyl(f"leg{sy}", (x, y, 0.16), (x + 0.01, y, 0.04), 0.008, leg, seg=8)
        for k, dy in enumerate((-0.02, 0.0, 0.02)):
            cyl(f"toe{sy}{k}", (x + 0.01, y, 0.04), (x + 0.055, y + dy, 0.04), 0.005, leg, seg=6)
    tail = [(-0.14, -0.03, 0.19), (-0.38, -0.06, 0.09), (-0.38, 0.06, 0.09), (-0.14, 0.03, 0.19),
            (-0.14, -0.03, 0.25), (-0.38, -0.06, 0.12), (-0.38, 0.06, 0.12), (-0.14, 0.03, 0.25)]
    from_pydata("tail", tail, [(0, 1, 2, 3), (7, 6, 5, 4), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)], wing)
    normalise()


def build_hammer():
    steel = mat("steel", (0.6, 0.62, 0.65), rough=0.35, metal=1.0)
    wood = mat("hickory", (0.7, 0.5, 0.3))
    grip = mat("grip", (0.1, 0.1, 0.1), rough=0.8)
    lathe("handle", [(0, 0), (0.018, 0), (0.02, 0.01), (0.019, 0.12), (0.016, 0.22), (0.015, 0.3),
                     (0.014, 0.33), (0, 0.33)], wood, seg=96, scale=(1.0, 0.7, 1))
    lathe("grip", [(0, -0.002), (0.021, -0.002), (0.023, 0.01), (0.022, 0.1), (0.02, 0.12), (0, 0.12)],
          grip, seg=96, scale=(1.0, 0.75, 1))
    # head along x: striking face at +x, claw at -x, eye over the handle top
    box("eye", (0, 0, 0.325), (0.04, 0.03, 0.04), steel, bevel=0.004)
    cyl("neck", (0.015, 0, 0.325), (0.07, 0, 0.325), 0.013, steel, seg=96)
    cyl("poll", (0.07, 0, 0.325), (0.1, 0, 0.325), 0.016, steel, seg=96)
    # claw: two prongs curving down, a slot between them
    for sy in (-1, 1):
        pts = [(-0.015, sy * 0.0055, 0.33)] + arc_points((-0.02, sy * 0.0055, 0.26), 0.07, 90, 155, 16)[1:]
        tube(f"claw{sy}", pts, [0.009 - 0.0004 * k for k in range(17)],
             steel, seg=32)
    normalise(rot_z=-15)


def build_wrench():
    steel = mat("steel", (0.62, 0.64, 0.67), rough=0.3, metal=1.0)
    dark = mat("knurl", (0.35, 0.36, 0.38), rough=0.5, metal=1.0)
    handle = box("handle", (0, 0, 0.12), (0.034, 0.012, 0.25), steel, bevel=0.005)
    hole = cyl("hole", (0, -0.05, 0.025), (0, 0.05, 0.025), 0.008, steel, seg=48)
    cut(handle, hole)
    lathe("handle.end", [(0, -0.006), (0.017, -0.006), (0.017, 0.006), (0, 0.006)], steel,
          center=(0, 0, 0), seg=48).data.transform(trs((0, 0, 0.0), (90, 0, 0)))
    head = cyl("head", (0, -0.008, 0.27), (0, 0.008, 0.27), 0.055, steel, seg=96)
    slot = box("slot", (0.0, 0, 0.32), (0.046, 0.1, 0.11), steel, rot=(0, 15, 0))
    cut(head, slot)
    # the movable jaw's worm screw across the head, below the slot
    cyl("worm", (-0.022, 0.0, 0.245), (0.022, 0.0, 0.245), 0.011, dark, seg=48)
    for k in range(7):
        x = -0.018 + 0.006 * k
        torus(f"thread{k}", (x, 0, 0.245), 0.011, 0.0022, dark, rot=(0, 90, 0), seg=32, minor_seg=10)
    normalise(rot_z=-10)


def chair(prefix, origin, wood, rot_z=0.0, height=1.0):
    """A wooden chair with a slatted back; seat 0.45 high, back 0.95 (scaled by height)."""
    ox, oy, oz = origin
    rot = Matrix.Rotation(math.radians(rot_z), 4, "Z")
    before = set(bpy.data.objects)

    def place(ob):
        ob.data.transform(Matrix.Translation((ox, oy, oz)) @ rot @ Matrix.Diagonal((height,) * 3 + (1,)))

    w, d, sh = 0.44, 0.42, 0.45
    box(f"{prefix}.seat", (0, 0, sh), (w + 0.02, d + 0.02, 0.035), wood, bevel=0.006, segs=6)
    for sx in (-1, 1):
        box(f"{prefix}.legf{sx}", (sx * w / 2 - sx * 0.02, -d / 2 + 0.02, sh / 2), (0.04, 0.04, sh), wood, bevel=0.005, segs=6)
        box(f"{prefix}.legb{sx}", (sx * w / 2 - sx * 0.02, d / 2 - 0.02, 0.48), (0.04, 0.04, 0.96), wood, bevel=0.005, segs=6)
        box(f"{prefix}.side{sx}", (sx * w / 2 - sx * 0.02, 0, 0.15), (0.025, d - 0.04, 0.03), wood, bevel=0.004, segs=6)
    box(f"{prefix}.front", (0, -d / 2 + 0.02, 0.15), (w - 0.04, 0.025, 0.03), wood, bevel=0.004, segs=6)
    for z in (0.62, 0.75, 0.88):
        box(f"{prefix}.slat{z}", (0, d / 2 - 0.02, z), (w - 0.04, 0.022, 0.06), wood, bevel=0.004, segs=6)
    for ob in sorted(set(bpy.data.objects) - before, key=lambda o: o.name):
        place(ob)


def build_chair():
    wood = mat("wood", (0.55, 0.34, 0.18))
    chair("chair", (0, 0, 0), wood)
    normalise(rot_z=-35)


def union_outline(ellipses, center, n=192):
    """Outline of a union of ellipses (cx, cz, a, b) that all contain `center`, in the x-z plane."""
    px, pz = center
    out = []
    for i in range(n):
        t = 2 * math.pi * i / n
        dx, dz = math.cos(t), math.sin(t)
        best = 0.0
        for cx, cz, a, b in ellipses:
            # solve ((px + s dx - cx)/a)^2 + ((pz + s dz - cz)/b)^2 = 1 for s > 0
            ux, uz = (px - cx) / a, (pz - cz) / b
            vx, vz = dx / a, dz / b
            A = vx * vx + vz * vz
            B = 2 * (ux * vx + uz * vz)
            C = ux * ux + uz * uz - 1
            s = (-B + math.sqrt(B * B - 4 * A * C)) / (2 * A)
            best = max(best, s)
        out.append((px + best * dx, pz + best * dz))
    return out


def prism(name, outline, center, y0, y1, material):
    """Extrude an outline (star-shaped about center, x-z plane) between y0 and y1."""
    verts = [(x, y0, z) for x, z in outline] + [(x, y1, z) for x, z in outline]
    n = len(outline)
    verts += [(center[0], y0, center[1]), (center[0], y1, center[1])]
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces.append((i, j, n + j, n + i))
        faces.append((2 * n, j, i))
        faces.append((2 * n + 1, n + i, n + j))
    ob = from_pydata(name, verts, faces, material, smooth=True, sharp_deg=50)
    return ob


def build_guitar():
    top = mat("spruce", (0.85, 0.66, 0.4))
    side = mat("rosewood", (0.42, 0.22, 0.12))
    black = mat("black", (0.04, 0.035, 0.03))
    fret = mat("fret", (0.75, 0.75, 0.72), rough=0.3, metal=1.0)
    ell = [(0, 0.22, 0.19, 0.24), (0, 0.5, 0.15, 0.19)]
    outline = union_outline(ell, (0, 0.37))
    prism("body.sides", outline, (0, 0.37), -0.045, 0.045, side)
    inner = [(x * 0.985, 0.37 + (z - 0.37) * 0.985) for x, z in outline]
    prism("body.top", inner, (0, 0.37), -0.05, -0.045, top)
    lathe("soundhole", [(0, 0), (0.045, 0), (0.045, 0.003), (0, 0.003)], black, seg=64).data.transform(
        trs((0, -0.05, 0.45), (90, 0, 0)))
    torus("rosette", (0, -0.052, 0.45), 0.055, 0.004, side, rot=(90, 0, 0), seg=64, minor_seg=6)
    box("bridge", (0, -0.056, 0.17), (0.12, 0.012, 0.025), black, bevel=0.003)
    box("neck", (0, -0.01, 0.82), (0.05, 0.045, 0.5), side, bevel=0.006)
    box("fretboard", (0, -0.038, 0.76), (0.054, 0.008, 0.52), black)
    for k in range(12):
        z = 0.55 + 0.44 * (1 - 0.5 ** ((12 - k) / 12.0)) * 1.8 - 0.06
        box(f"fret{k}", (0, -0.043, z + 0.12), (0.054, 0.004, 0.003), fret)
    box("head", (0, 0.0, 1.14), (0.075, 0.02, 0.17), side, rot=(-10, 0, 0), bevel=0.006)
    for k in range(3):
        z = 1.09 + 0.05 * k
        for sx in (-1, 1):
            cyl(f"peg{sx}{k}", (sx * 0.035, z * 0.0 + 0.004 * k, z), (sx * 0.07, 0.004 * k, z), 0.006, fret, seg=16)
            ellipsoid(f"key{sx}{k}", (sx * 0.075, 0.004 * k, z), (0.006, 0.012, 0.016), fret, seg=16, rings=8)
    for k in range(6):
        x0 = -0.025 + 0.01 * k
        cyl(f"string{k}", (x0, -0.064, 0.17), (x0 * 0.8, -0.046, 1.06), 0.0012, fret, seg=4, smooth=False)
    normalise(rot_z=-25)


def build_still_life():
    table = mat("table", (0.5, 0.32, 0.18))
    glass = mat("bottle", (0.15, 0.4, 0.22), rough=0.2)
    china = mat("china", (0.9, 0.9, 0.86), rough=0.3)
    bowl_m = mat("bowl", (0.35, 0.5, 0.7), rough=0.4)
    steel = mat("steel", (0.7, 0.72, 0.75), rough=0.25, metal=1.0)
    wood = mat("handle", (0.2, 0.12, 0.07))
    box("tabletop", (-0.05, -0.02, -0.03), (1.0, 0.62, 0.06), table, bevel=0.01)
    bottle = [(0, 0), (0.07, 0), (0.075, 0.01), (0.075, 0.3), (0.07, 0.34), (0.05, 0.38),
              (0.03, 0.42), (0.024, 0.46), (0.024, 0.54), (0.028, 0.545), (0.028, 0.56),
              (0.02, 0.565), (0.018, 0.55), (0, 0.55)]
    lathe("bottle", bottle, glass, center=(-0.45, 0.12, 0), seg=40)
    cup = [(0, 0.008), (0.04, 0.0), (0.05, 0.005), (0.052, 0.03), (0.06, 0.1), (0.062, 0.11),
           (0.056, 0.11), (0.054, 0.1), (0.046, 0.03), (0, 0.02)]
    lathe("cup", cup, china, center=(-0.2, -0.15, 0), seg=40)
    handle = arc_points((-0.262, -0.15, 0.058), 0.03, -80, 80, 10, plane="xz")
    tube("cup.handle", [(2 * -0.262 - x, y, z) for x, y, z in handle], 0.007, china, seg=8, caps=True)
    bowl = [(0, 0.0), (0.07, 0.0), (0.075, 0.01), (0.13, 0.04), (0.17, 0.09), (0.19, 0.13),
            (0.18, 0.13), (0.16, 0.095), (0.12, 0.05), (0.07, 0.022), (0, 0.02)]
    bx, by = 0.2, 0.1
    lathe("bowl", bowl, bowl_m, center=(bx, by, 0), seg=48)
    ellipsoid("orange", (bx - 0.06, by - 0.03, 0.1), (0.065,) * 3, mat("orange", (0.95, 0.5, 0.08)))
    ellipsoid("apple", (bx + 0.06, by + 0.02, 0.1), (0.062, 0.062, 0.055), mat("apple", (0.75, 0.1, 0.08)))
    cyl("apple.stalk", (bx + 0.06, by + 0.02, 0.15), (bx + 0.065, by + 0.02, 0.18), 0.004, wood, seg=6)
    ellipsoid("lemon", (bx, by + 0.06, 0.15), (0.07, 0.045, 0.045), mat("lemon", (0.95, 0.85, 0.2)), rot=(0, 0, 20))
    # knife lying on the table, blade towards +x
    kx, ky = 0.0, -0.25
    blade = [(kx, ky - 0.012, 0.004), (kx + 0.22, ky - 0.012, 0.004), (kx + 0.26, ky + 0.01, 0.004),
             (kx, ky + 0.014, 0.004),
             (kx, ky - 0.012, 0.0), (kx + 0.22, ky - 0.012, 0.0), (kx + 0.26, ky + 0.01, 0.0),
             (kx, ky + 0.014, 0.0)]
    from_pydata("knife.blade", blade, [(0, 1, 2, 3), (7, 6, 5, 4), (0, 4, 5, 1), (1, 5, 6, 2),
                                       (2, 6, 7, 3), (3, 7, 4, 0)], steel)
    box("knife.handle", (kx - 0.06, ky + 0.001, 0.011), (0.12, 0.024, 0.022), wood, bevel=0.006)
    for k in range(2):
        ellipsoid(f"rivet{k}", (kx - 0.09 + 0.06 * k, ky + 0.001, 0.022), (0.005, 0.005, 0.002), steel, seg=8, rings=4)
    # turn the knife so it points away from the viewer at an angle and shows its length
    turn = Matrix.Translation((kx, ky, 0)) @ Matrix.Rotation(math.radians(25), 4, "Z") @ Matrix.Translation((-kx, -ky, 0))
    for ob in bpy.context.scene.objects:
        if ob.name.startswith(("knife", "rivet")):
            ob.data.transform(turn)
    normalise(rot_z=0)


def build_room():
    floor = mat("floor", (0.55, 0.42, 0.3))
    wall = mat("wall", (0.82, 0.8, 0.72))
    wall2 = mat("wall.side", (0.7, 0.76, 0.8))
    wood = mat("wood", (0.5, 0.3, 0.16))
    box("floor", (0, 0, -0.025), (3.0, 3.0, 0.05), floor)
    box("wall.back", (0, 1.525, 1.25), (3.0, 0.05, 2.5), wall)
    box("wall.left", (-1.525, 0, 1.25), (0.05, 3.1, 2.5), wall2)
    box("skirting", (0, 1.49, 0.05), (3.0, 0.02, 0.1), wood)
    # a framed picture and a window on the walls
    box("picture.frame", (0.2, 1.49, 1.6), (0.7, 0.03, 0.5), wood)
    box("picture", (0.2, 1.47, 1.6), (0.6, 0.02, 0.4), mat("picture", (0.3, 0.45, 0.6)))
    box("window", (-1.49, -0.3, 1.5), (0.03, 0.9, 0.8), mat("sky", (0.75, 0.88, 1.0)))
    box("window.frame", (-1.485, -0.3, 1.5), (0.01, 1.0, 0.9), wood)
    # table
    tx, ty = 0.2, 0.55
    box("table.top", (tx, ty, 0.74), (1.1, 0.7, 0.04), wood, bevel=0.008)
    for sx in (-1, 1):
        for sy in (-1, 1):
            box(f"table.leg{sx}{sy}", (tx + sx * 0.5, ty + sy * 0.3, 0.36), (0.05, 0.05, 0.72), wood)
    chair("chair", (tx - 0.1, ty - 0.55, 0), mat("chair", (0.6, 0.4, 0.22)), rot_z=180 + 15)
    # floor lamp in the corner
    metal = mat("lamp.metal", (0.15, 0.15, 0.15), rough=0.4, metal=1.0)
    shade = mat("lamp.shade", (0.95, 0.88, 0.65))
    lx, ly = -1.15, 1.15
    lathe("lamp.base", [(0, 0), (0.17, 0), (0.17, 0.02), (0.05, 0.04), (0, 0.04)], metal, center=(lx, ly, 0))
    cyl("lamp.pole", (lx, ly, 0.03), (lx, ly, 1.45), 0.014, metal)
    lathe("lamp.shade", [(0.22, 1.35), (0.12, 1.65), (0.115, 1.65), (0.215, 1.35)], shade, center=(lx, ly, 0), seg=40)
    ellipsoid("lamp.bulb", (lx, ly, 1.45), (0.05,) * 3, mat("bulb", (1.0, 0.97, 0.85)))
    # a cup and a book on the table
    lathe("cup", [(0, 0.76), (0.04, 0.76), (0.045, 0.86), (0.04, 0.86), (0.036, 0.77), (0, 0.77)],
          mat("cup", (0.9, 0.9, 0.88)), center=(tx + 0.25, ty - 0.1, 0))
    box("book", (tx - 0.2, ty + 0.05, 0.78), (0.25, 0.18, 0.04), mat("book", (0.6, 0.15, 0.12)), rot=(0, 0, 20))
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = 28
    cam = bpy.data.objects.new("camera", cam_data)
    bpy.context.scene.collection.objects.link(cam)
    cam.location = (2.2, -2.8, 1.7)
    target = Vector((-0.3, 0.5, 0.7))
    cam.rotation_euler = (target - cam.location).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = cam
    normalise()


def build_teakettle():
    body_m = mat("enamel", (0.75, 0.12, 0.1), rough=0.3)
    black = mat("black", (0.06, 0.06, 0.06), rough=0.5)
    steel = mat("steel", (0.7, 0.7, 0.72), rough=0.3, metal=1.0)
    prof = [(0, 0), (0.14, 0), (0.16, 0.01), (0.175, 0.04), (0.18, 0.08), (0.175, 0.12),
            (0.16, 0.16), (0.135, 0.195), (0.1, 0.22), (0.075, 0.23), (0.075, 0.24), (0.065, 0.24),
            (0.065, 0.232), (0, 0.232)]
    lathe("body", prof, body_m, seg=96, sharp_deg=60)
    lathe("lid", [(0, 0.232), (0.078, 0.232), (0.076, 0.242), (0.05, 0.255), (0, 0.258)], body_m, seg=64)
    lathe("knob", [(0, 0.255), (0.012, 0.255), (0.01, 0.27), (0.022, 0.28), (0.02, 0.295), (0, 0.3)], black, seg=48)
    spout = [(0.13, 0, 0.08), (0.19, 0, 0.12), (0.23, 0, 0.17), (0.26, 0, 0.22), (0.29, 0, 0.26)]
    tube("spout", spout, [0.04, 0.032, 0.025, 0.02, 0.018], body_m, seg=32, caps=False)
    lathe("spout.tip", [(0.018, 0), (0.012, 0), (0, 0)], black, seg=32).data.transform(
        trs((0.29, 0, 0.26), (0, 43, 0)))
    # arched handle over the top, on two posts
    for sx in (-1, 1):
        cyl(f"post{sx}", (sx * 0.1, 0, 0.2), (sx * 0.1, 0, 0.27), 0.008, steel, seg=10)
    arc = arc_points((0, 0, 0.27), 0.1, 0, 180, 48, plane="xz")
    tube("handle", arc, 0.018, black, seg=20)
    normalise(rot_z=-20)


def build_bicycle():
    frame = mat("frame", (0.15, 0.35, 0.65), rough=0.3)
    tyre = mat("tyre", (0.06, 0.06, 0.06), rough=0.9)
    steel = mat("steel", (0.7, 0.7, 0.72), rough=0.3, metal=1.0)
    black = mat("black", (0.1, 0.1, 0.1), rough=0.6)
    R = Vector((-0.52, 0, 0.34))
    F = Vector((0.52, 0, 0.34))
    B = Vector((-0.08, 0, 0.3))
    S = Vector((-0.2, 0, 0.82))
    H = Vector((0.34, 0, 0.82))
    Hb = Vector((0.38, 0, 0.68))
    for name, c in (("rear", R), ("front", F)):
        torus(f"{name}.tyre", c, 0.32, 0.022, tyre, rot=(90, 0, 0), seg=64, minor_seg=10)
        torus(f"{name}.rim", c, 0.295, 0.01, steel, rot=(90, 0, 0), seg=64, minor_seg=6)
        cyl(f"{name}.hub", c - Vector((0, 0.04, 0)), c + Vector((0, 0.04, 0)), 0.02, steel, seg=12)
        for k in range(16):
            a = 2 * math.pi * (k + 0.5 * (name == "front")) / 16
            side = 0.03 if k % 2 else -0.03
            end = c + Vector((0.29 * math.cos(a), 0, 0.29 * math.sin(a)))
            cyl(f"{name}.spoke{k}", c + Vector((0, side, 0)), end, 0.0025, steel, seg=4, smooth=False)
    r = 0.02
    cyl("seat.tube", B, S + Vector((0.0, 0, 0.02)), r, frame)
    cyl("top.tube", S, H, r, frame)
    cyl("down.tube", B, Hb, r * 1.2, frame)
    cyl("head.tube", Hb - Vector((0.01, 0, 0.03)), H + Vector((-0.01, 0, 0.04)), r * 1.2, frame)
    for sy in (-1, 1):
        off = Vector((0, sy * 0.04, 0))
        cyl(f"seat.stay{sy}", S + Vector((0, 0, -0.03)), R + off, r * 0.6, frame)
        cyl(f"chain.stay{sy}", B, R + off, r * 0.6, frame)
        cyl(f"fork{sy}", Hb, F + off, r * 0.7, frame)
    stem = H + Vector((-0.02, 0, 0.1))
    cyl("stem", H, stem, r * 0.8, steel)
    tube("handlebar", [stem + Vector((-0.08, -0.24, 0)), stem + Vector((0, -0.2, 0)), stem, stem + Vector((0, 0.2, 0)),
                       stem + Vector((-0.08, 0.24, 0))], 0.012, steel, seg=10)
    for sy in (-1, 1):
        cyl(f"grip{sy}", stem + Vector((-0.06, sy * 0.225, 0)), stem + Vector((-0.1, sy * 0.25, 0)), 0.017, black)
    post = S + Vector((-0.03, 0, 0.12))
    cyl("seat.post", S, post, 0.013, steel)
    saddle = [(post.x + 0.1, 0, post.z + 0.02), (post.x + 0.03, 0, post.z + 0.03), (post.x - 0.06, 0, post.z + 0.035)]
    tube("saddle", saddle, [0.02, 0.04, 0.07], black, seg=16)
    lathe("chainring", [(0, -0.005), (0.1, -0.005), (0.1, 0.005), (0, 0.005)], steel, seg=40).data.transform(
        trs(B + Vector((0, -0.05, 0)), (90, 0, 0)))
    for sy, ang in ((-1, -60), (1, 120)):
        end = B + Vector((0.17 * math.cos(math.radians(ang)), sy * 0.07, 0.17 * math.sin(math.radians(ang))))
        cyl(f"crank{sy}", B + Vector((0, sy * 0.06, 0)), end, 0.01, steel, seg=8)
        box(f"pedal{sy}", end + Vector((0, sy * 0.05, 0)), (0.09, 0.08, 0.02), black)
    normalise()


# ---------------------------------------------------------------- second set


def interp(prof, z):
    """Linear interpolation in a list of (z, value) pairs sorted by z."""
    if z <= prof[0][0]:
        return prof[0][1]
    for (z0, v0), (z1, v1) in zip(prof, prof[1:]):
        if z <= z1:
            return v0 + (v1 - v0) * (z - z0) / (z1 - z0)
    return prof[-1][1]


def slab(name, zs, halfwidth, front, back, material, nx=24, sharp_deg=50):
    """A flat body in the x-z plane: rows at heights zs, half-width halfwidth(z) along x;
    front(u, z) and back(u, z) give how far the -y and +y faces stand out at u = x / w in
    [-1, 1] (they must agree at u = +-1 for a clean rim). A closed grid mesh."""
    bm = bmesh.new()
    grids = []
    for side, off in ((-1, front), (1, back)):
        grid = []
        for z in zs:
            w = halfwidth(z)
            row = []
            for j in range(nx + 1):
                u = -1 + 2 * j / nx
                row.append(bm.verts.new((w * u, side * off(u, z), z)))
            grid.append(row)
        grids.append(grid)
    rows = len(zs)
    for grid in grids:
        for i in range(rows - 1):
            for j in range(nx):
                bm.faces.new((grid[i][j], grid[i][j + 1], grid[i + 1][j + 1], grid[i + 1][j]))
    loop = ([(0, j) for j in range(nx + 1)] + [(i, nx) for i in range(1, rows)]
            + [(rows - 1, j) for j in range(nx - 1, -1, -1)] + [(i, 0) for i in range(rows - 2, 0, -1)])
    f, b = grids
    for k in range(len(loop)):
        (i0, j0), (i1, j1) = loop[k], loop[(k + 1) % len(loop)]
        bm.faces.new((f[i0][j0], f[i1][j1], b[i1][j1], b[i0][j0]))
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces[:])
    return link(name, bm, material, smooth=True, sharp_deg=sharp_deg)


def quad_prism(name, bottom, top, material, smooth=False):
    """A hexahedron from its four bottom and four top corners (same winding)."""
    faces = [(0, 1, 2, 3), (7, 6, 5, 4), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)]
    return from_pydata(name, list(bottom) + list(top), faces, material, smooth=smooth)


def tapered_board(name, z0, z1, w0, w1, y0, y1, material):
    """A board along z with half-width w0 at z0 and w1 at z1, between depths y0 and y1."""
    return quad_prism(name, [(-w0, y0, z0), (w0, y0, z0), (w0, y1, z0), (-w0, y1, z0)],
                      [(-w1, y0, z1), (w1, y0, z1), (w1, y1, z1), (-w1, y1, z1)], material)


def orient(z_axis, x_hint):
    """A rotation matrix whose z axis is z_axis and whose x axis leans towards x_hint."""
    zv = Vector(z_axis).normalized()
    xv = Vector(x_hint)
    xv = (xv - zv * xv.dot(zv)).normalized()
    yv = zv.cross(xv)
    return Matrix((xv, yv, zv)).transposed().to_4x4()


def u_bend(a, b, c, n=12):
    """A U of tube: straight from a to the bend, a half circle, straight on to c; the bend
    turns about b (a and c are the two ends, b the middle of the bend's chord)."""
    a, b, c = Vector(a), Vector(b), Vector(c)
    half = (c - a) / 2
    r = half.length
    out = b - (a + half)
    start, end = b - half, b + half
    pts = [a, a + (start - a) * 0.5, start]
    for k in range(1, n):
        t = math.pi * k / n
        pts.append(b - half * math.cos(t) + out.normalized() * r * math.sin(t))
    pts += [end, c + (end - c) * 0.5, c]
    return pts


def build_violin():
    varnish = mat("varnish", (0.6, 0.27, 0.08), rough=0.35)
    ebony = mat("ebony", (0.05, 0.04, 0.035), rough=0.4)
    maple = mat("maple", (0.85, 0.7, 0.5))
    string = mat("string", (0.8, 0.8, 0.78), rough=0.3, metal=1.0)
    # outline: lower bout, the corners and the C-bouts of the waist, upper bout
    # (height, half-width) pairs
    outline = [(-0.004, 0.006), (-0.003, 0.018), (-0.001, 0.03), (0.002, 0.04), (0.006, 0.052), (0.012, 0.066),
               (0.025, 0.084), (0.045, 0.098), (0.07, 0.105),
               (0.1, 0.104), (0.125, 0.098), (0.145, 0.091), (0.153, 0.092), (0.16, 0.078), (0.172, 0.065),
               (0.192, 0.059), (0.212, 0.064), (0.224, 0.077), (0.23, 0.085), (0.238, 0.079), (0.26, 0.083),
               (0.285, 0.085), (0.31, 0.082), (0.33, 0.074), (0.345, 0.06), (0.355, 0.043), (0.36, 0.03),
               (0.363, 0.018), (0.364, 0.006)]
    zs = sorted({z for z, _ in outline} | {0.36 * k / 48 for k in range(1, 48)})
    rib, arch = 0.016, 0.013

    def w(z):
        return interp(outline, z)

    def plate(u, z):
        return rib + arch * min(1.0, w(z) / 0.06) * (1 - u * u) ** 1.5

    slab("body", zs, w, plate, plate, varnish, nx=28, sharp_deg=40)

    def top_y(x, z):
        return -plate(x / w(z), z) - 0.0008

    for sx in (-1, 1):
        pts = []
        for k in range(13):
            s = k / 12
            z = 0.148 + 0.075 * s
            x = sx * (0.027 + 0.016 * (1 - s) + 0.005 * math.sin(2 * math.pi * s))
            pts.append((x, top_y(x, z), z))
        tube(f"fhole{sx}", pts, 0.0022, ebony, seg=8)
        for p in (pts[0], pts[-1]):
            ellipsoid(f"fhole.eye{sx}", p, (0.0045, 0.002, 0.0045), ebony, seg=12, rings=6)
    top = -(rib + arch)
    tapered_board("neck", 0.355, 0.49, 0.014, 0.012, -0.016, 0.004, varnish)
    tapered_board("fingerboard", 0.25, 0.49, 0.022, 0.012, top - 0.014, -0.016, ebony)
    tapered_board("pegbox", 0.485, 0.565, 0.013, 0.011, -0.03, 0.006, varnish)
    # the scroll: a tube spiralling inward at the head, seen from the side as a snail
    spiral = []
    for k in range(41):
        t = 2.4 * math.pi * k / 40
        r = 0.026 * (1 - 0.11 * t)
        spiral.append((0, -0.012 + r * math.sin(t), 0.575 + r * math.cos(t)))
    tube("scroll", spiral, [0.012 - 0.0011 * k / 4 for k in range(41)], varnish, seg=16)
    for k, z in enumerate((0.497, 0.513, 0.529, 0.545)):
        sx = -1 if k % 2 else 1
        cyl(f"peg{k}", (-sx * 0.018, -0.012, z), (sx * 0.03, -0.012, z), 0.0035, ebony, seg=12)
        ellipsoid(f"peg.head{k}", (sx * 0.038, -0.012, z), (0.01, 0.004, 0.009), ebony, seg=16, rings=8)
    tapered_board("tailpiece", 0.012, 0.105, 0.01, 0.02, top - 0.006, top + 0.004, ebony)
    cyl("endpin", (0, 0, 0.002), (0, 0, -0.01), 0.005, ebony, seg=12)
    tapered_board("bridge", 0.183, 0.187, 0.024, 0.024, top - 0.026, top + 0.002, maple)
    for k in range(4):
        x = -0.0165 + 0.011 * k
        pts = [(x * 0.8, top - 0.007, 0.1), (x, top - 0.027, 0.185), (x * 0.55, top - 0.015, 0.489)]
        tube(f"string{k}", pts, 0.0007, string, seg=6, caps=False)
    normalise(rot_z=-35)


def build_mandolin():
    spruce = mat("spruce", (0.88, 0.72, 0.45))
    bowl = mat("bowl", (0.45, 0.2, 0.1), rough=0.35)
    black = mat("black", (0.04, 0.035, 0.03), rough=0.4)
    metal = mat("metal", (0.78, 0.78, 0.75), rough=0.3, metal=1.0)
    L, W = 0.32, 0.125
    ts = [0.5 - 0.5 * math.cos(math.pi * k / 40) for k in range(41)]
    zs = [L * t for t in ts]

    def w(z):
        t = min(max(z / L, 0.0), 1.0)
        return max(0.012, W * math.sin(math.pi * t ** 0.78) ** 0.65)

    slab("top", zs, w, lambda u, z: 0.006, lambda u, z: 0.0, spruce, nx=28)
    slab("bowl", zs, w, lambda u, z: -0.001,
         lambda u, z: 0.001 + 0.85 * w(z) * math.sqrt(max(0.0, 1 - u * u)), bowl, nx=28)
    # ribs of the bowl: thin light lines along its staves
    for k in (-2, -1, 0, 1, 2):
        u = k / 3.0
        pts = [(w(z) * u, 0.001 + 0.85 * w(z) * math.sqrt(max(0.0, 1 - u * u)) + 0.0012, z) for z in zs[2:-2]]
        tube(f"stave{k}", pts, 0.0018, spruce, seg=6)
    hole = (0, -0.0065, 0.2)
    lathe("soundhole", [(0, 0), (0.038, 0), (0.038, 0.002), (0, 0.002)], black, seg=64).data.transform(
        trs(hole, (90, 0, 0)))
    torus("rosette", (0, -0.0075, 0.2), 0.045, 0.0035, black, rot=(90, 0, 0), seg=64, minor_seg=6)
    ellipsoid("pickguard", (0.06, -0.0066, 0.15), (0.03, 0.001, 0.055), black, rot=(0, -25, 0), seg=24, rings=8)
    tapered_board("bridge", 0.085, 0.092, 0.04, 0.04, -0.02, -0.006, black)
    tapered_board("tailpiece", -0.004, 0.03, 0.018, 0.025, -0.012, -0.004, metal)
    tapered_board("neck", 0.3, 0.58, 0.016, 0.013, -0.014, 0.012, bowl)
    tapered_board("fingerboard", 0.26, 0.58, 0.018, 0.015, -0.021, -0.014, black)
    for k in range(14):
        z = 0.58 - 0.32 * (1 - 2 ** (-k / 12.0)) * 1.9
        tapered_board(f"fret{k}", z, z + 0.0025, 0.018, 0.018, -0.0225, -0.02, metal)
    tapered_board("head", 0.575, 0.7, 0.02, 0.027, -0.016, -0.004, bowl)
    for k in range(4):
        z = 0.6 + 0.028 * k
        for sx in (-1, 1):
            cyl(f"tuner{sx}{k}", (sx * 0.015, 0.0, z), (sx * 0.05, 0.0, z), 0.003, metal, seg=10)
            ellipsoid(f"button{sx}{k}", (sx * 0.055, 0.0, z), (0.006, 0.009, 0.008), mat("pearl", (0.95, 0.93, 0.88)),
                      seg=16, rings=8)
    for k in range(8):
        x = -0.0175 + 0.005 * k
        pts = [(x * 0.9, -0.014, 0.02), (x, -0.021, 0.09), (x * 0.6, -0.024, 0.58), (x * 0.6, -0.017, 0.64)]
        tube(f"string{k}", pts, 0.0006, metal, seg=5, caps=False)
    normalise(rot_z=-35)


def build_wine():
    wood = mat("table", (0.45, 0.28, 0.15))
    bottle_m = mat("bottle", (0.1, 0.3, 0.15), rough=0.15)
    label = mat("label", (0.93, 0.88, 0.74))
    foil = mat("foil", (0.5, 0.05, 0.08), rough=0.3, metal=0.6)
    glass = mat("glass", (0.82, 0.88, 0.9), rough=0.05)
    wine = mat("wine", (0.45, 0.03, 0.08), rough=0.15)
    top_z = 0.5
    lathe("table.top", [(0, top_z - 0.03), (0.25, top_z - 0.03), (0.262, top_z - 0.02), (0.262, top_z - 0.005),
                        (0.25, top_z), (0, top_z)], wood, seg=96)
    lathe("table.column", [(0, 0.04), (0.03, 0.04), (0.022, 0.1), (0.025, 0.24), (0.035, 0.27), (0.025, 0.3),
                           (0.022, top_z - 0.05), (0.05, top_z - 0.03), (0, top_z - 0.03)], wood, seg=48)
    lathe("table.foot", [(0, 0), (0.17, 0), (0.17, 0.015), (0.12, 0.035), (0.04, 0.05), (0, 0.05)], wood, seg=64)
    bx, by = -0.09, 0.05
    prof = [(0, 0.012), (0.03, 0.0), (0.038, 0.0), (0.04, 0.01), (0.04, 0.22), (0.036, 0.245), (0.025, 0.265),
            (0.016, 0.28), (0.0135, 0.3), (0.0135, 0.36), (0, 0.36)]
    lathe("bottle", [(r, top_z + z) for r, z in prof], bottle_m, center=(bx, by, 0), seg=64)
    lathe("label", [(0.0405, top_z + 0.06), (0.0405, top_z + 0.16)], label, center=(bx, by, 0), seg=64)
    lathe("capsule", [(0.0145, top_z + 0.31), (0.0145, top_z + 0.362), (0.012, top_z + 0.365), (0, top_z + 0.365)],
          foil, center=(bx, by, 0), seg=48)
    gx, gy = 0.1, -0.05
    lathe("glass.foot", [(0, top_z), (0.034, top_z), (0.034, top_z + 0.003), (0.008, top_z + 0.008),
                         (0.004, top_z + 0.012), (0.004, top_z + 0.085), (0.012, top_z + 0.092), (0, top_z + 0.092)],
          glass, center=(gx, gy, 0), seg=64)
    wl = top_z + 0.135  # the wine line

    def bowl_r(z):
        t = (z - (top_z + 0.09)) / 0.125
        return 0.041 * math.sin(math.pi * (0.05 + 0.55 * t)) ** 0.7

    lower = [(bowl_r(top_z + 0.09 + (wl - top_z - 0.09) * k / 10), top_z + 0.09 + (wl - top_z - 0.09) * k / 10)
             for k in range(11)]
    lathe("glass.wine", [(0, top_z + 0.09)] + lower + [(0, wl)], wine, center=(gx, gy, 0), seg=64)
    upper = [(bowl_r(wl + (top_z + 0.215 - wl) * k / 12), wl + (top_z + 0.215 - wl) * k / 12) for k in range(13)]
    inner = [(r - 0.0025, z) for r, z in reversed(upper)]
    lathe("glass.bowl", upper + inner, glass, center=(gx, gy, 0), seg=64, sharp_deg=80)
    normalise(rot_z=-15)


def build_table_lamp():
    brass = mat("brass", (0.8, 0.6, 0.25), rough=0.3, metal=1.0)
    ceramic = mat("ceramic", (0.2, 0.4, 0.55), rough=0.25)
    shade = mat("shade", (0.95, 0.9, 0.75), rough=0.8)
    bulb = mat("bulb", (1.0, 0.97, 0.85), rough=0.2)
    lathe("base", [(0, 0), (0.16, 0), (0.165, 0.012), (0.155, 0.03), (0.11, 0.05), (0.05, 0.07), (0.03, 0.075),
                   (0, 0.075)], brass, seg=96)
    vase = [(0, 0.07), (0.05, 0.07), (0.09, 0.1), (0.115, 0.16), (0.11, 0.22), (0.07, 0.28), (0.035, 0.31),
            (0.03, 0.33), (0, 0.33)]
    lathe("body", vase, ceramic, seg=96, sharp_deg=80)
    cyl("stem", (0, 0, 0.33), (0, 0, 0.52), 0.012, brass, seg=32)
    for z in (0.34, 0.43):
        lathe(f"collar{z}", [(0, z), (0.022, z), (0.026, z + 0.01), (0.022, z + 0.02), (0, z + 0.02)], brass, seg=48)
    lathe("socket", [(0, 0.51), (0.022, 0.51), (0.022, 0.56), (0, 0.56)], brass, seg=48)
    lathe("bulb", [(0, 0.56), (0.012, 0.56), (0.016, 0.58), (0.03, 0.61), (0.032, 0.63), (0.025, 0.655),
                   (0.012, 0.665), (0, 0.667)], bulb, seg=48)
    lo, hi = 0.42, 0.75
    outer = [(0.3, lo), (0.3, lo + 0.012), (0.14, hi - 0.012), (0.14, hi)]
    inner = [(0.134, hi), (0.294, lo)]
    lathe("shade", outer + inner + [(0.3, lo + 0.0001)], shade, seg=96, sharp_deg=30)
    # harp holding the shade: a wire loop from the socket up to the shade's top ring
    for a in (0, 180):
        c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
        tube(f"harp{a}", [(0.022 * c, 0.022 * s, 0.54), (0.08 * c, 0.08 * s, 0.62), (0.135 * c, 0.135 * s, hi)],
             0.003, brass, seg=8)
    lathe("finial", [(0, hi), (0.012, hi), (0.016, hi + 0.015), (0.01, hi + 0.03), (0, hi + 0.035)], brass, seg=32)
    cyl("finial.post", (0, 0, 0.667), (0, 0, hi), 0.003, brass, seg=8)
    tube("cord", [(0.0, 0.1, 0.02), (0.05, 0.22, 0.005), (0.2, 0.3, 0.005), (0.32, 0.28, 0.005)],
         0.006, mat("cord", (0.1, 0.1, 0.1)), seg=10)
    normalise(rot_z=-15)


def build_scissors():
    steel = mat("steel", (0.72, 0.74, 0.77), rough=0.25, metal=1.0)
    handle_m = mat("handle", (0.85, 0.2, 0.1), rough=0.4)
    pivot = Vector((0, 0, 0.33))
    # two pieces, each a blade above the pivot and a finger ring below it on the other side
    for side, y0 in ((1, -0.008), (-1, 0.0)):
        rot = trs(pivot, (0, -side * 11, 0)) @ Matrix.Translation(-pivot)
        before = set(bpy.data.objects)
        # blade: straight cutting edge on the centre line, curved back on the far side from its ring
        outline = [(0.0, 0.3), (0.0, 0.86), (-side * 0.004, 0.9)]
        for k in range(1, 12):
            t = k / 12
            outline.append((-side * (0.004 + 0.048 * math.sin(math.pi / 2 * t) ** 0.6), 0.9 - 0.6 * t))
        outline.append((-side * 0.046, 0.28))
        cx = sum(p[0] for p in outline) / len(outline)
        cz = sum(p[1] for p in outline) / len(outline)
        prism(f"blade{side}", outline, (cx, cz), y0, y0 + 0.008, steel)
        # shank down to the finger ring on the other side of the pivot
        ring_c = Vector((side * 0.075, y0 + 0.004, 0.1))
        tube(f"shank{side}", [(-side * 0.012, y0 + 0.004, 0.31), (side * 0.03, y0 + 0.004, 0.24),
                              (side * 0.05, y0 + 0.004, 0.18)], [0.012, 0.012, 0.013], handle_m, seg=16)
        ring = []
        for k in range(97):
            a = 2 * math.pi * k / 96
            rx = 0.065 * math.cos(a) * (1 + 0.15 * side * math.cos(a))
            ring.append(ring_c + Vector((rx, 0, 0.085 * math.sin(a))))
        tube(f"ring{side}", ring, 0.014, handle_m, seg=24, caps=False)
        for ob in sorted(set(bpy.data.objects) - before, key=lambda o: o.name):
            ob.data.transform(rot)
    cyl("pivot", (0, -0.014, 0.33), (0, 0.014, 0.33), 0.012, steel, seg=32)
    for sy in (-1, 1):
        ellipsoid(f"pivot.head{sy}", (0, sy * 0.014, 0.33), (0.014, 0.004, 0.014), steel, seg=24, rings=12)
    normalise(rot_z=-10)


def build_cat():
    fur = mat("fur", (0.85, 0.5, 0.2))
    white = mat("white", (0.95, 0.92, 0.86))
    pink = mat("pink", (0.9, 0.55, 0.55))
    iris = mat("iris", (0.55, 0.7, 0.15), rough=0.2)
    black = mat("black", (0.02, 0.02, 0.02), rough=0.2)
    for sx in (-1, 1):
        ellipsoid(f"haunch{sx}", (sx * 0.085, 0.06, 0.11), (0.075, 0.14, 0.11), fur, seg=40, rings=20)
        ellipsoid(f"hindpaw{sx}", (sx * 0.1, -0.06, 0.02), (0.035, 0.06, 0.022), fur, seg=24, rings=12)
        capsule(f"foreleg{sx}", (sx * 0.05, -0.06, 0.28), (sx * 0.045, -0.11, 0.035), 0.03, fur, r2=0.024, seg=24)
        ellipsoid(f"forepaw{sx}", (sx * 0.045, -0.135, 0.02), (0.03, 0.045, 0.022), white, seg=24, rings=12)
    ellipsoid("body", (0, 0.03, 0.24), (0.12, 0.15, 0.2), fur, rot=(12, 0, 0), seg=48, rings=24)
    ellipsoid("chest", (0, -0.055, 0.3), (0.085, 0.07, 0.12), white, seg=40, rings=20)
    ellipsoid("head", (0, -0.06, 0.5), (0.1, 0.09, 0.085), fur, seg=48, rings=24)
    for sx in (-1, 1):
        ellipsoid(f"cheek{sx}", (sx * 0.05, -0.1, 0.47), (0.05, 0.045, 0.04), fur, seg=24, rings=12)
        ellipsoid(f"muzzle{sx}", (sx * 0.018, -0.145, 0.465), (0.024, 0.018, 0.018), white, seg=24, rings=12)
        ellipsoid(f"eye{sx}", (sx * 0.04, -0.133, 0.515), (0.018, 0.01, 0.014), iris, rot=(0, sx * 10, sx * -20),
                  seg=24, rings=12)
        ellipsoid(f"pupil{sx}", (sx * 0.04, -0.142, 0.515), (0.004, 0.003, 0.012), black, rot=(0, 0, sx * -20),
                  seg=12, rings=6)
        # ear: a pyramid, the inside pink
        base = [Vector((sx * 0.025, -0.07, 0.565)), Vector((sx * 0.09, -0.07, 0.54)), Vector((sx * 0.06, -0.03, 0.56))]
        tip = Vector((sx * 0.075, -0.065, 0.66))
        from_pydata(f"ear{sx}", [*base, tip], [(0, 1, 2), (0, 1, 3), (1, 2, 3), (2, 0, 3)], fur)
        inner = [base[0] + Vector((sx * 0.01, -0.003, 0.01)), base[1] + Vector((-sx * 0.008, -0.003, 0.008)),
                 tip + Vector((0, -0.003, -0.02))]
        from_pydata(f"ear.inner{sx}", inner + [(inner[0] + inner[1] + inner[2]) / 3 + Vector((0, 0.006, 0))],
                    [(0, 1, 2), (0, 1, 3), (1, 2, 3), (2, 0, 3)], pink)
        for k, dz in enumerate((-0.006, 0.004)):
            cyl(f"whisker{sx}{k}", (sx * 0.03, -0.155, 0.465 + dz), (sx * 0.12, -0.14, 0.47 + 2.5 * dz), 0.0012,
                white, seg=4, smooth=False)
    ellipsoid("nose", (0, -0.158, 0.482), (0.011, 0.006, 0.008), pink, seg=16, rings=8)
    # tail from the rump round the right side to lie in front of the front paws
    tail = [(-0.02, 0.19, 0.05)]
    for k in range(17):
        a = math.radians(80 - 180 * k / 16)
        r = 0.19 - 0.02 * k / 16
        tail.append((r * math.cos(a) * (1.05 if k < 8 else 1.0), r * math.sin(a), 0.026))
    tail.append((-0.09, -0.19, 0.024))
    tube("tail", tail, [0.028] * 16 + [0.026, 0.024, 0.02], fur, seg=20)
    normalise(rot_z=-25)


def build_armchair():
    fabric = mat("fabric", (0.25, 0.42, 0.38), rough=0.9)
    cushion = mat("cushion", (0.3, 0.5, 0.45), rough=0.9)
    wood = mat("wood", (0.3, 0.18, 0.1))
    W, D = 0.86, 0.8
    for sx in (-1, 1):
        for sy in (-1, 1):
            cyl(f"leg{sx}{sy}", (sx * (W / 2 - 0.06), sy * (D / 2 - 0.06), 0.1),
                (sx * (W / 2 - 0.05), sy * (D / 2 - 0.05), 0.0), 0.025, wood, r2=0.017, seg=16)
    box("base", (0, 0, 0.23), (W, D, 0.26), fabric, bevel=0.04, segs=8)
    box("seat", (0, -0.04, 0.42), (W - 0.3, D - 0.12, 0.13), cushion, bevel=0.05, segs=8)
    box("back", (0, D / 2 - 0.09, 0.62), (W, 0.18, 0.72), fabric, rot=(-8, 0, 0), bevel=0.07, segs=8)
    box("back.cushion", (0, D / 2 - 0.23, 0.66), (W - 0.32, 0.14, 0.42), cushion, rot=(-10, 0, 0), bevel=0.06, segs=8)
    for sx in (-1, 1):
        x = sx * (W / 2 - 0.075)
        box(f"arm{sx}", (x, -0.02, 0.47), (0.15, D - 0.04, 0.26), fabric, bevel=0.05, segs=8)
        cyl(f"arm.roll{sx}", (x + sx * 0.005, -D / 2 + 0.01, 0.6), (x + sx * 0.005, D / 2 - 0.1, 0.6), 0.085,
            fabric, seg=64)
        lathe(f"arm.front{sx}", [(0, 0), (0.07, 0), (0.08, 0.012), (0, 0.016)], cushion, seg=48).data.transform(
            trs((x + sx * 0.005, -D / 2 + 0.005, 0.6), (90, 0, 0)))
    normalise(rot_z=-30)


def build_vase_of_flowers():
    glaze = mat("glaze", (0.2, 0.35, 0.7), rough=0.2)
    stem_m = mat("stem", (0.2, 0.45, 0.15))
    leaf_m = mat("leaf", (0.15, 0.5, 0.18))
    vase = [(0, 0), (0.07, 0), (0.075, 0.01), (0.11, 0.08), (0.12, 0.13), (0.105, 0.2), (0.065, 0.27),
            (0.05, 0.31), (0.055, 0.34), (0.065, 0.36), (0.058, 0.36), (0.047, 0.33), (0, 0.33)]
    lathe("vase", vase, glaze, seg=96, sharp_deg=60)
    flowers = [  # stem end (x, y, z), petal colour, centre colour
        ((0.0, -0.04, 0.95), (0.85, 0.1, 0.12), (0.2, 0.12, 0.05)),
        ((-0.22, -0.02, 0.82), (0.95, 0.8, 0.15), (0.45, 0.25, 0.08)),
        ((0.22, 0.0, 0.84), (0.95, 0.95, 0.92), (0.95, 0.75, 0.1)),
        ((-0.13, -0.08, 0.62), (0.95, 0.5, 0.65), (0.95, 0.8, 0.2)),
        ((0.12, -0.12, 0.68), (0.5, 0.3, 0.75), (0.95, 0.8, 0.2)),
    ]
    for n, (end, petal_rgb, centre_rgb) in enumerate(flowers):
        end = Vector(end)
        start = Vector((end.x * 0.12, end.y * 0.12, 0.25))
        midp = Vector((end.x * 0.45, end.y * 0.45, 0.36 + 0.55 * (end.z - 0.36)))
        pts = [start.lerp(midp, k / 6) for k in range(6)] + [midp.lerp(end, k / 6) for k in range(7)]
        tube(f"stem{n}", pts, 0.007, stem_m, seg=10)
        # heads turned mostly towards the viewer (-y), a little along their stems
        facing = (0.45 * (end - midp).normalized() + Vector((0, -1, 0.1))).normalized()
        m = Matrix.Translation(end) @ orient(facing, (1, 0, 0))
        petal_m = mat(f"petal{n}", petal_rgb)
        for k in range(8):
            a = 2 * math.pi * k / 8
            ob = ellipsoid(f"petal{n}.{k}", (0, 0, 0), (0.045, 0.02, 0.006), petal_m, seg=16, rings=8)
            ob.data.transform(m @ Matrix.Rotation(a, 4, "Z") @ trs((0.045, 0, 0.004), (0, -12, 0)))
        ob = ellipsoid(f"centre{n}", (0, 0, 0), (0.022, 0.022, 0.012), mat(f"centre{n}", centre_rgb), seg=20, rings=10)
        ob.data.transform(m @ Matrix.Translation((0, 0, 0.01)))
        # a leaf on each stem, springing outward from its middle
        base = start.lerp(midp, 0.9)
        out = Vector((end.x, end.y, 0)).normalized() if abs(end.x) + abs(end.y) > 1e-6 else Vector((1, 0, 0))
        if n == 0:
            out = Vector((-1, 0, 0))
        leaf_dir = (out + Vector((0, 0, 0.7))).normalized()
        ob = ellipsoid(f"leaf{n}", (0, 0, 0), (0.004, 0.022, 0.06), leaf_m, seg=16, rings=8)
        ob.data.transform(Matrix.Translation(base + leaf_dir * 0.055) @ orient(leaf_dir, (0, -1, 0)))
    normalise(rot_z=0)


def build_pipe():
    briar = mat("briar", (0.5, 0.26, 0.12), rough=0.35)
    vulcanite = mat("vulcanite", (0.05, 0.05, 0.05), rough=0.3)
    char = mat("char", (0.12, 0.08, 0.06))
    silver = mat("silver", (0.8, 0.8, 0.82), rough=0.2, metal=1.0)
    bowl = [(0, 0), (0.012, 0.001), (0.026, 0.008), (0.036, 0.02), (0.041, 0.038), (0.043, 0.06),
            (0.044, 0.085), (0.043, 0.1), (0.04, 0.104), (0.028, 0.104), (0.025, 0.1), (0.024, 0.04),
            (0.02, 0.03), (0, 0.028)]
    lathe("bowl", bowl, briar, seg=128, sharp_deg=50)
    lathe("tobacco", [(0, 0.07), (0.0245, 0.07), (0.0245, 0.075), (0, 0.078)], char, seg=48)
    shank = [(0.03, 0, 0.034), (0.06, 0, 0.036), (0.09, 0, 0.04), (0.11, 0, 0.043)]
    tube("shank", shank, [0.017, 0.015, 0.014, 0.0135], briar, seg=48)
    cyl("band", (0.108, 0, 0.043), (0.118, 0, 0.0445), 0.0145, silver, seg=32)
    stem = [(0.118, 0, 0.0445)]
    for k in range(1, 21):
        t = k / 20
        stem.append((0.118 + 0.2 * t, 0, 0.0445 + 0.035 * math.sin(math.pi * t * 0.8) - 0.01 * t))
    tube("stem", stem, [0.012 - 0.0045 * k / 20 for k in range(21)], vulcanite, seg=48)
    lip = Vector(stem[-1])
    ellipsoid("bit", lip + Vector((0.008, 0, 0.0)), (0.016, 0.012, 0.0045), vulcanite, rot=(0, -12, 0),
              seg=32, rings=12)
    normalise(rot_z=-20)


def build_trumpet():
    brass = mat("brass", (0.85, 0.62, 0.22), rough=0.3, metal=1.0)
    pearl = mat("pearl", (0.95, 0.93, 0.86), rough=0.3)
    silver = mat("silver", (0.8, 0.8, 0.82), rough=0.25, metal=1.0)
    r = 0.0075
    zt, zb = 0.15, 0.06  # the upper and lower runs of tubing
    valves = (0.3, 0.34, 0.38)
    for k, x in enumerate(valves):
        cyl(f"valve{k}", (x, 0, 0.03), (x, 0, 0.18), 0.016, brass, seg=32)
        for z in (0.03, 0.18):
            lathe(f"valve.cap{k}{z}", [(0, -0.008), (0.018, -0.008), (0.018, 0.008), (0, 0.008)], brass,
                  center=(x, 0, z), seg=32)
        cyl(f"valve.stem{k}", (x, 0, 0.188), (x, 0, 0.215), 0.004, silver, seg=12)
        lathe(f"button{k}", [(0, 0), (0.014, 0), (0.015, 0.004), (0.013, 0.007), (0, 0.008)], pearl,
              center=(x, 0, 0.215), seg=32)
        lathe(f"valve.bottom{k}", [(0.014, 0), (0.01, -0.015), (0, -0.018)], brass, center=(x, 0, 0.022), seg=32)
    # bell section: from the third valve out to the bell, and the big bend back behind the valves
    tube("bell.pipe", [(valves[2], 0, zt), (0.5, 0, zt)], r, brass, seg=20)
    bell_len = 0.32
    outer = [(0.0075 + 0.058 * (k / 24) ** 4, bell_len * k / 24) for k in range(25)]
    prof = [(0, 0)] + outer + [(0.068, bell_len + 0.002), (0.064, bell_len + 0.004)] + \
           [(rr - 0.002, z) for rr, z in reversed(outer[12:])] + [(0, outer[12][1])]
    lathe("bell", prof, brass, seg=64, sharp_deg=60).data.transform(trs((0.5, 0, zt), (0, 90, 0)))
    tube("bell.bend", u_bend((valves[0], 0, zt), (0.04, 0, (zt + zb) / 2), (valves[0], 0, zb)), r, brass, seg=20)
    # leadpipe from the mouthpiece, in front of the valves, to the main tuning slide and back
    lead = [(0.02, -0.03, 0.105), (0.3, -0.03, 0.105)]
    tube("leadpipe", lead + u_bend((0.46, -0.03, 0.105), (0.53, -0.03, 0.075), (0.46, -0.03, 0.045))[1:] +
         [(0.4, -0.015, 0.045), (valves[2], 0, 0.045)], [0.0055] + [r] * 23, brass, seg=20)
    lathe("mouthpiece", [(0, 0), (0.006, 0), (0.006, 0.045), (0.012, 0.07), (0.015, 0.085), (0.014, 0.088),
                         (0.009, 0.083), (0, 0.078)], silver, seg=40).data.transform(
        trs((0.04, -0.03, 0.105), (0, -90, 0)))
    # valve slides behind the valves
    v1, v2, v3 = valves
    for name, a, b, c in (("slide1", (v1, 0.022, 0.12), (0.18, 0.022, 0.1), (v1, 0.022, 0.08)),
                          ("slide2", (v2 - 0.01, 0.022, 0.05), (v2, 0.022, -0.03), (v2 + 0.01, 0.022, 0.05)),
                          ("slide3", (v3, 0.022, 0.12), (0.5, 0.022, 0.1), (v3, 0.022, 0.08))):
        tube(name, u_bend(a, b, c), r * 0.85, brass, seg=16)
    for k, x in enumerate((0.1, 0.46)):
        cyl(f"brace{k}", (x, -0.03, 0.105), (x, 0, zt), 0.003, brass, seg=8)
    normalise(rot_z=-35)


def room_camera(loc, target, lens=28):
    """The scene's camera at `loc`, looking at `target`."""
    cd = bpy.data.cameras.new("camera")
    cd.lens = lens
    cam = bpy.data.objects.new("camera", cd)
    bpy.context.scene.collection.objects.link(cam)
    cam.location = loc
    cam.rotation_euler = (Vector(target) - cam.location).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = cam


def sofa(x, y, mat_):
    """A three-seat sofa centred at (x, y) on the floor, its back towards +y."""
    box("sofa.seat", (x, y, 0.22), (1.8, 0.8, 0.24), mat_, bevel=0.04)
    box("sofa.back", (x, y + 0.32, 0.6), (1.8, 0.18, 0.56), mat_, bevel=0.05)
    for sx in (-1, 1):
        box(f"sofa.arm{sx}", (x + sx * 0.95, y, 0.4), (0.16, 0.8, 0.5), mat_, bevel=0.05)
    box("sofa.cushion", (x - 0.4, y + 0.15, 0.48), (0.4, 0.15, 0.35), mat("cushion", (0.75, 0.6, 0.25)), rot=(10, 0, 5), bevel=0.05)


def build_lounge():
    """A sitting room: three walls 15 cm thick, the camera inside."""
    fl = mat("floor", (0.45, 0.33, 0.24))
    wa = mat("wall", (0.85, 0.82, 0.75))
    wb = mat("wall.b", (0.68, 0.74, 0.7))
    box("floor", (0, 0, -0.075), (5.0, 4.0, 0.15), fl)
    box("wall.back", (0, 2.075, 1.3), (5.3, 0.15, 2.6), wa)
    box("wall.left", (-2.575, 0, 1.3), (0.15, 4.0, 2.6), wb)
    box("wall.right", (2.575, 0, 1.3), (0.15, 4.0, 2.6), wb)
    sofa(0, 1.4, mat("sofa", (0.3, 0.38, 0.5)))
    wood = mat("wood", (0.45, 0.28, 0.15))
    box("coffee.top", (0, 0.2, 0.42), (1.0, 0.55, 0.05), wood, bevel=0.01)
    for sx in (-1, 1):
        for sy in (-1, 1):
            box(f"coffee.leg{sx}{sy}", (sx * 0.45, 0.2 + sy * 0.22, 0.2), (0.04, 0.04, 0.4), wood)
    lathe("bowl", [(0, 0.445), (0.1, 0.445), (0.16, 0.5), (0.17, 0.53), (0.16, 0.53), (0.09, 0.46), (0, 0.46)], mat("bowl", (0.85, 0.8, 0.7)), center=(0.15, 0.2, 0))
    for k, (dx, dy, c) in enumerate(((0.1, 0.18, (0.8, 0.5, 0.1)), (0.2, 0.22, (0.6, 0.1, 0.1)), (0.15, 0.14, (0.4, 0.6, 0.15)))):
        ellipsoid(f"fruit{k}", (dx, dy, 0.51), (0.045,) * 3, mat(f"fruit{k}", c))
    pot = mat("pot", (0.6, 0.32, 0.2))
    lathe("plant.pot", [(0, 0), (0.15, 0), (0.2, 0.4), (0.19, 0.4), (0, 0.4)], pot, center=(-1.9, 1.5, 0))
    leaf = mat("leaf", (0.2, 0.4, 0.18))
    for k in range(7):
        a = k * 2 * math.pi / 7
        ellipsoid(f"leaf{k}", (-1.9 + 0.22 * math.cos(a), 1.5 + 0.22 * math.sin(a), 0.75 + 0.1 * (k % 3)), (0.25, 0.06, 0.03), leaf, rot=(0, -35, math.degrees(a)))
    box("picture.frame", (0.0, 1.99, 1.7), (1.0, 0.03, 0.7), wood)
    box("picture", (0.0, 1.97, 1.7), (0.9, 0.02, 0.6), mat("picture", (0.7, 0.45, 0.3)))
    room_camera((0.4, -1.7, 1.3), (0.0, 1.0, 0.55), lens=24)
    normalise()


def build_kitchen():
    """A kitchen: a floor and one wall, a table with a bottle and a jug, two chairs."""
    fl = mat("floor", (0.6, 0.55, 0.48))
    wa = mat("wall", (0.78, 0.7, 0.55))
    box("floor", (0, 0, -0.04), (4.0, 3.5, 0.08), fl)
    box("wall", (0, 1.79, 1.4), (4.0, 0.08, 2.8), wa)
    wood = mat("wood", (0.5, 0.32, 0.18))
    box("table.top", (0, 0.5, 0.75), (1.4, 0.8, 0.05), wood, bevel=0.01)
    for sx in (-1, 1):
        for sy in (-1, 1):
            box(f"table.leg{sx}{sy}", (sx * 0.62, 0.5 + sy * 0.33, 0.37), (0.06, 0.06, 0.74), wood)
    chair("chairL", (-0.45, -0.1, 0), mat("chair", (0.55, 0.36, 0.2)), rot_z=180 - 10)
    chair("chairR", (0.95, 0.55, 0), mat("chair", (0.55, 0.36, 0.2)), rot_z=90)
    glass = mat("bottle", (0.15, 0.35, 0.2), rough=0.2)
    lathe("bottle", [(0, 0.775), (0.04, 0.775), (0.04, 0.98), (0.015, 1.04), (0.015, 1.08), (0, 1.08)], glass, center=(-0.2, 0.55, 0))
    lathe("jug", [(0, 0.775), (0.07, 0.775), (0.09, 0.85), (0.07, 0.95), (0.08, 0.99), (0, 0.99)], mat("jug", (0.85, 0.82, 0.75)), center=(0.2, 0.45, 0))
    box("shelf", (-1.0, 1.7, 1.6), (1.2, 0.1, 0.04), wood)
    for k in range(4):
        lathe(f"plate{k}", [(0, 1.62), (0.1, 1.62), (0.12, 1.64), (0, 1.64)], mat("plate", (0.9, 0.9, 0.88)), center=(-1.45 + 0.3 * k, 1.7, 0))
    room_camera((0.3, -2.4, 1.5), (0.0, 0.6, 0.8), lens=30)
    normalise()


def build_attic():
    """A seated figure in an attic: floor and two walls 25 cm thick, a window in one."""
    build_figure(True)
    fl = mat("floor", (0.5, 0.4, 0.3))
    wa = mat("wall", (0.8, 0.78, 0.7))
    box("floor", (0, 0, -0.125), (3.5, 3.0, 0.25), fl)
    box("wall.back", (0, 1.625, 1.5), (3.5, 0.25, 3.0), wa)
    box("wall.left", (-1.875, 0, 1.5), (0.25, 3.0, 3.0), wa)
    box("window", (-1.74, 0.2, 1.6), (0.03, 0.8, 1.0), mat("sky", (0.75, 0.88, 1.0)))
    room_camera((2.0, -3.2, 1.6), (-0.2, 0.3, 0.7), lens=30)
    normalise()


def sweep(width=7.0, front=-3.5, back=2.2, radius=1.2, height=4.5, depth_segs=16):
    """A studio sweep behind the normalised subject: a floor at z = 0 from y = `front` curving
    up (a quarter circle of `radius`) into a wall at y = `back`, one layer, `width` wide."""
    profile = [(front, 0.0), (back - radius, 0.0)]
    for k in range(1, depth_segs):
        a = math.pi / 2 * k / depth_segs
        profile.append((back - radius + radius * math.sin(a), radius - radius * math.cos(a)))
    profile += [(back, radius), (back, height)]
    xs = [-width / 2 + width * i / 6 for i in range(7)]
    verts = [(x, y, z) for x in xs for (y, z) in profile]
    m = len(profile)
    faces = [(i * m + j, (i + 1) * m + j, (i + 1) * m + j + 1, i * m + j + 1)
             for i in range(len(xs) - 1) for j in range(m - 1)]
    from_pydata("sweep", verts, faces, mat("sweep", (0.82, 0.8, 0.76)), smooth=True, sharp_deg=30)


def on_sweep(build, camera=None):
    """`build`'s subject on a studio sweep, seen by `camera` ((location, target)) if given."""
    def scene():
        build()
        sweep()
        if camera:
            room_camera(*camera, lens=50)
    return scene


SCENES = [
    ("head-bust", build_head_bust, True),
    ("figure-standing", lambda: build_figure(False), True),
    ("figure-seated", lambda: build_figure(True), True),
    ("horse", build_horse, True),
    ("bird", build_bird, True),
    ("hammer", build_hammer, True),
    ("wrench", build_wrench, True),
    ("chair", build_chair, True),
    ("guitar", build_guitar, True),
    ("still-life", build_still_life, True),
    ("room", build_room, True),
    ("teakettle", build_teakettle, True),
    ("bicycle", build_bicycle, True),
    ("zup-figure", lambda: build_figure(False), False),
]

# the second set, kept unseen for a later round of blind judging
SECOND_SET = [
    ("violin", build_violin, True),
    ("mandolin", build_mandolin, True),
    ("wine-bottle-and-glass", build_wine, True),
    ("table-lamp", build_table_lamp, True),
    ("scissors", build_scissors, True),
    ("cat", build_cat, True),
    ("armchair", build_armchair, True),
    ("vase-of-flowers", build_vase_of_flowers, True),
    ("pipe", build_pipe, True),
    ("trumpet", build_trumpet, True),
]

# the third set: rooms built of separate slabs, for the framing of open rooms
ROOMS = [
    ("lounge", build_lounge, True),
    ("kitchen", build_kitchen, True),
    ("attic", build_attic, True),
]

# the fourth set: subjects on a studio sweep (a floor curving up into a wall, one mesh)
SWEEPS = [
    ("sweep-horse", on_sweep(build_horse), True),
    ("sweep-head", on_sweep(build_head_bust, ((1.2, -4.5, 1.4), (0.0, 0.0, 0.9))), True),
    ("sweep-teakettle", on_sweep(build_teakettle, ((-1.5, -4.0, 1.8), (0.0, 0.0, 0.6))), True),
    ("sweep-chair", on_sweep(build_chair), True),
]


def main(argv):
    if len(argv) < 2 or argv[1].startswith("-"):
        print("usage: make-look-scenes.py OUT_DIR [NAME...]", file=sys.stderr)
        return 2
    out = argv[1]
    only = set(argv[2:])
    if "second" in only:
        only = (only - {"second"}) | {name for name, _, _ in SECOND_SET}
    if "rooms" in only:
        only = (only - {"rooms"}) | {name for name, _, _ in ROOMS}
    if "sweeps" in only:
        only = (only - {"sweeps"}) | {name for name, _, _ in SWEEPS}
    known = {name for name, _, _ in SCENES + SECOND_SET + ROOMS + SWEEPS}
    if only - known:
        print(f"make-look-scenes.py: unknown scene {sorted(only - known)[0]!r}", file=sys.stderr)
        return 2
    os.makedirs(out, exist_ok=True)
    for name, build, yup in SCENES + SECOND_SET + ROOMS + SWEEPS:
        if (only and name not in only) or (not only and (name, build, yup) not in SCENES):
            continue
        reset()
        build()
        tris = 0
        for o in bpy.context.scene.objects:
            if o.type == "MESH":
                o.data.calc_loop_triangles()
                tris += len(o.data.loop_triangles)
        export(os.path.join(out, name + ".glb"), yup=yup)
        print(f"{name}: {tris} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
