"""Build an animated Blender scene for measuring painted animation: a moving camera and a moving object.

Usage: python make-anim-scene.py OUT.glb   (bpy 5.0.1 importable)

Why: the painted animation (`cubist render --frames`) is measured on Fox and CesiumMan (a
figure walking, still camera) and on a turntable (`--orbit`, the renderer's own camera). A
scene made in Blender, with its own camera keyframed and an object moving under it, is what a
Blender user hands the renderer: this builds one, on Blender's timeline.

The scene: a still life on a table top (a bottle, a bowl of three fruit, a cup) and a jug that
slides across the table towards the bowl, turning a quarter about its axis, while the scene's
camera dollies in and orbits 15 degrees about the table; a sun lights it. Blender frames 1-12
(24 fps) are keyed on every frame and exported as Blender exports by default, an animation per
object (the jug's and the camera's: `cubist render --frames` plays both), with *Set All glTF
Animation Starting at 0*, so Blender's frame 1 is time 0 and `cubist render --frames 1-12`
renders Blender's frames 1-12 (without it Blender writes frame f at f / 24 s, one frame later
than cubist's frame f). About 11,000 triangles.

Deterministic: the same bpy gives the same bytes on every run (the shapes come from
make-look-scenes.py, built vertex by vertex). Check it with
`cubist render OUT.glb --frames 1-12 --preset plain --camera perspective -o /tmp/anim/p_##.png`.
"""

import importlib.util
import math
import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("look_scenes", os.path.join(_HERE, "make-look-scenes.py"))
look = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(look)  # imports bpy (with Blender's user files kept out of the home directory)

import bpy  # noqa: E402
from mathutils import Matrix, Vector  # noqa: E402

FIRST, LAST = 1, 12  # Blender's frames, keyed on every one
FPS = 24
TARGET = Vector((0.0, 0.05, 0.14))  # what the camera looks at: the table's middle, above its top


def build_table_and_still_life():
    """A table top (its top face at height 0) on four legs, a bottle, a bowl of fruit and a cup."""
    wood = look.mat("table", (0.5, 0.32, 0.18))
    look.box("tabletop", (0, 0, -0.03), (1.3, 0.8, 0.06), wood, bevel=0.01)
    for sx in (-1, 1):
        for sy in (-1, 1):
            look.box(f"table.leg{sx}{sy}", (sx * 0.58, sy * 0.33, -0.41), (0.06, 0.06, 0.7), wood)
    bottle = [(0, 0), (0.07, 0), (0.075, 0.01), (0.075, 0.3), (0.07, 0.34), (0.05, 0.38),
              (0.03, 0.42), (0.024, 0.46), (0.024, 0.54), (0.028, 0.545), (0.028, 0.56),
              (0.02, 0.565), (0.018, 0.55), (0, 0.55)]
    look.lathe("bottle", bottle, look.mat("bottle", (0.15, 0.4, 0.22), rough=0.2), center=(-0.42, 0.2, 0), seg=40)
    bowl = [(0, 0.0), (0.07, 0.0), (0.075, 0.01), (0.13, 0.04), (0.17, 0.09), (0.19, 0.13),
            (0.18, 0.13), (0.16, 0.095), (0.12, 0.05), (0.07, 0.022), (0, 0.02)]
    bx, by = 0.3, 0.15
    look.lathe("bowl", bowl, look.mat("bowl", (0.35, 0.5, 0.7), rough=0.4), center=(bx, by, 0), seg=48)
    look.ellipsoid("orange", (bx - 0.06, by - 0.03, 0.1), (0.065,) * 3, look.mat("orange", (0.95, 0.5, 0.08)))
    look.ellipsoid("apple", (bx + 0.06, by + 0.02, 0.1), (0.062, 0.062, 0.055), look.mat("apple", (0.75, 0.1, 0.08)))
    look.ellipsoid("lemon", (bx, by + 0.06, 0.15), (0.07, 0.045, 0.045), look.mat("lemon", (0.95, 0.85, 0.2)),
                   rot=(0, 0, 20))
    cup = [(0, 0.008), (0.04, 0.0), (0.05, 0.005), (0.052, 0.03), (0.06, 0.1), (0.062, 0.11),
           (0.056, 0.11), (0.054, 0.1), (0.046, 0.03), (0, 0.02)]
    look.lathe("cup", cup, look.mat("china", (0.9, 0.9, 0.86), rough=0.3), center=(-0.1, 0.22, 0), seg=40)


def build_jug():
    """A jug with a handle and a spout, built about its own origin (its base's centre), one object."""
    glaze = look.mat("jug", (0.62, 0.2, 0.12), rough=0.35)
    body = [(0, 0), (0.07, 0), (0.075, 0.01), (0.095, 0.06), (0.1, 0.11), (0.085, 0.17), (0.065, 0.21),
            (0.068, 0.24), (0.074, 0.25), (0.066, 0.25), (0.058, 0.22), (0.075, 0.17), (0.088, 0.11),
            (0.083, 0.06), (0.06, 0.02), (0, 0.02)]
    jug = look.lathe("jug", body, glaze, seg=48)
    handle = look.tube("jug.handle", [(-0.07, 0, 0.2), (-0.12, 0, 0.2), (-0.15, 0, 0.16), (-0.14, 0, 0.11),
                                      (-0.09, 0, 0.075)], 0.011, glaze, seg=10)
    spout = look.from_pydata("jug.spout", [(0.06, -0.03, 0.215), (0.06, 0.03, 0.215), (0.11, 0, 0.255),
                                           (0.065, 0, 0.19)], [(0, 1, 2), (0, 2, 3), (1, 3, 2), (0, 3, 1)], glaze)
    # the handle and spout ride on the body: children of its node, so the body's keys move them
    handle.parent = jug
    spout.parent = jug
    return jug


def add_sun():
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(50), 0, math.radians(-35))
    bpy.context.scene.collection.objects.link(sun)


def add_camera():
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    cam.data.lens = 35
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    return cam


def animate(cam, jug):
    """Key the camera (dolly in 12%, orbit 15 degrees) and the jug (slide and turn) on every frame."""
    scene = bpy.context.scene
    scene.render.fps = FPS
    scene.frame_start, scene.frame_end = FIRST, LAST
    # the glTF camera's vertical field of view is Blender's at this aspect: the renders' own
    scene.render.resolution_x, scene.render.resolution_y = 480, 360
    for f in range(FIRST, LAST + 1):
        t = (f - FIRST) / (LAST - FIRST)
        azimuth = math.radians(-62 + 15 * t)
        distance = 1.95 * (1 - 0.12 * t)
        cam.location = TARGET + Vector((distance * math.cos(azimuth) * 0.82, distance * math.sin(azimuth) * 0.82,
                                        distance * 0.57))
        cam.rotation_euler = (TARGET - cam.location).to_track_quat("-Z", "Y").to_euler()
        cam.keyframe_insert("location", frame=f)
        cam.keyframe_insert("rotation_euler", frame=f)
        jug.location = (-0.3 + 0.3 * t, -0.2 + 0.04 * t, 0)
        jug.rotation_euler = (0, 0, math.radians(200 + 90 * t))
        jug.keyframe_insert("location", frame=f)
        jug.keyframe_insert("rotation_euler", frame=f)
    scene.frame_set(FIRST)


def export(path):
    bpy.ops.export_scene.gltf(
        filepath=path, export_format="GLB", export_apply=True, export_yup=True,
        export_cameras=True, export_lights=True, export_animations=True,
        export_anim_slide_to_zero=True,
    )


def main(argv):
    if len(argv) != 2 or argv[1].startswith("-"):
        print("usage: make-anim-scene.py OUT.glb", file=sys.stderr)
        return 2
    look.reset()
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    build_table_and_still_life()
    jug = build_jug()
    add_sun()
    animate(add_camera(), jug)
    tris = 0
    for o in bpy.context.scene.objects:
        if o.type == "MESH":
            o.data.calc_loop_triangles()
            tris += len(o.data.loop_triangles)
    os.makedirs(os.path.dirname(os.path.abspath(argv[1])), exist_ok=True)
    export(argv[1])
    print(f"{argv[1]}: {tris} triangles, frames {FIRST}-{LAST}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
