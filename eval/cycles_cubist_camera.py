"""Cycles through an OSL version of the spherical cubist camera (SPEC "Cameras", eq 4.2): the
peer a Blender user would compare `cubist render` with.

Imports a glTF scene into headless Blender (bpy 5.0.1 from .venv: `bash scripts/setup-python.sh`),
places a custom (OSL) camera whose rays start on a sphere of radius d around the focal centre C
and point at it, rotated by x * alpha_x about up and y * alpha_y about right (alpha_y = alpha /
aspect, as the thesis's listing), and renders once with Cycles on the CPU at the given samples.
Prints one JSON line: the render's wall and CPU seconds (bpy.ops.render.render with its PNG write: scene
import and Blender start-up are not counted, which favours Cycles) and the
settings used.

    .venv/bin/python eval/cycles_cubist_camera.py ../shared/models/venus_11k.glb \
        --size 1000 --samples 16 --angle 140 --output /tmp/cycles.png

C is the centre of the scene's bounding box, the view direction the scene's -Z (glTF's front
view), d twice the bounding radius: every ray meets the object, as in SPEC's measurement.
Lighting: the key, fill and rim suns `cubist` uses when a scene has none (shading.rs), and
Cycles' default grey world. Denoising is off (it would only add time to Cycles).
"""

import argparse
import json
import math
import os
import resource
import sys
import tempfile
import time

# The spherical camera of eq 4.2 in Cycles' camera space (origin at the camera, +Z the view
# direction, +Y up, +X right): unit outward v = right sin(x ax) cos(y ay) + (-forward cos(y ay)
# + up sin(y ay)) cos(x ax) ... as src/camera/spherical.rs writes it; origin C + d v, direction -v.
OSL_CAMERA = """
shader cubist_spherical(float angle_x = 2.443461, float angle_y = 2.443461, float focal_distance = 2.0,
                        output point position = 0, output vector direction = 0,
                        output color throughput = 1)
{
    point raster = camera_shader_raster_position();
    float x = raster[0] - 0.5;
    float y = raster[1] - 0.5;
    float st = sin(x * angle_x), ct = cos(x * angle_x);
    float sp = sin(y * angle_y), cp = cos(y * angle_y);
    vector outward = vector(st, sp * ct, -cp * ct);
    position = point(0, 0, 0) + outward * focal_distance;
    direction = -outward;
}
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--size", type=int, default=1000)
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--angle", type=float, default=140.0, help="convergence angle alpha, degrees")
    ap.add_argument("--output", default=None, help="PNG of the Cycles render (optional)")
    args = ap.parse_args()

    os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="cubist-cycles-"))
    import bpy
    from mathutils import Euler, Matrix, Vector

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(args.scene))
    scene = bpy.context.scene
    meshes = [o for o in scene.objects if o.type == "MESH"]
    if not meshes:
        sys.exit(f"{args.scene}: no mesh")
    corners = [o.matrix_world @ Vector(c) for o in meshes for c in o.bound_box]
    lo = Vector(tuple(min(c[i] for c in corners) for i in range(3)))
    hi = Vector(tuple(max(c[i] for c in corners) for i in range(3)))
    centre = (lo + hi) / 2
    radius = (hi - lo).length / 2

    # glTF -Z (the front view) is Blender's +Y after the importer's axis conversion; Blender's
    # camera looks down its local -Z with +Y up: aim it along +Y with +Z up.
    cam_data = bpy.data.cameras.new("cubist")
    cam_data.type = "CUSTOM"
    # An external .osl file: Cycles compiles it itself (an internal text block is only
    # compiled by the interface's update, not in background mode).
    osl_path = os.path.join(tempfile.mkdtemp(prefix="cubist-osl-"), "cubist_spherical.osl")
    with open(osl_path, "w") as f:
        f.write(OSL_CAMERA)
    cam_data.custom_mode = "EXTERNAL"
    cam_data.custom_filepath = osl_path
    cam = bpy.data.objects.new("cubist", cam_data)
    scene.collection.objects.link(cam)
    cam.matrix_world = Matrix.Translation(centre) @ Euler((math.pi / 2, 0.0, 0.0)).to_matrix().to_4x4()
    scene.camera = cam
    alpha = math.radians(args.angle)
    params = cam_data.cycles_custom
    params["angle_x"] = alpha
    params["angle_y"] = alpha * args.size / args.size
    params["focal_distance"] = 2.0 * radius

    # The rig cubist lights a scene without lights with (shading.rs): key, fill, rim, as suns
    # relative to the view (forward +Y, up +Z, right +X here).
    fwd, up, right = Vector((0, 1, 0)), Vector((0, 0, 1)), Vector((1, 0, 0))
    for name, to_light, strength in [
        ("key", -0.55 * fwd + 0.7 * up - 0.45 * right, 3.0),
        ("fill", -0.5 * fwd + 0.1 * up + 0.85 * right, 1.0),
        ("rim", 0.75 * fwd + 0.55 * up + 0.2 * right, 0.8),
    ]:
        light = bpy.data.lights.new(name, "SUN")
        light.energy = strength
        obj = bpy.data.objects.new(name, light)
        scene.collection.objects.link(obj)
        obj.rotation_euler = (-to_light.normalized()).to_track_quat("-Z", "Y").to_euler()

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x = args.size
    scene.render.resolution_y = args.size
    scene.render.resolution_percentage = 100
    scene.render.filepath = args.output or os.path.join(tempfile.mkdtemp(), "cycles.png")

    usage = lambda: resource.getrusage(resource.RUSAGE_SELF)  # noqa: E731
    u0, t0 = usage(), time.perf_counter()
    bpy.ops.render.render(write_still=True)
    wall = time.perf_counter() - t0
    u1 = usage()
    cpu = (u1.ru_utime - u0.ru_utime) + (u1.ru_stime - u0.ru_stime)
    # A camera shader that fails to compile renders the world only: refuse such a figure.
    image = bpy.data.images.load(scene.render.filepath)
    px = list(image.pixels)[::4 * 97]
    if max(px) - min(px) < 0.05:
        sys.exit("the render is uniform: the OSL camera did not run (see Cycles' errors above)")
    print(
        json.dumps(
            {
                "scene": args.scene,
                "size": args.size,
                "samples": args.samples,
                "angle_deg": args.angle,
                "threads": scene.render.threads,
                "render_wall_s": round(wall, 3),
                "render_cpu_s": round(cpu, 3),
                "blender": bpy.app.version_string,
                "load_average": os.getloadavg(),
            }
        )
    )


if __name__ == "__main__":
    main()
