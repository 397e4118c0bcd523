"""The add-on's exporter (blender_addon/export.py) in headless Blender (bpy 5.0.1): the GLB it
writes from the depsgraph holds what Blender renders (triangles, corner normals, UVs, colour
attributes, materials, instances, camera, lights), renders like Blender's own glTF exporter's
file, and the whole F12 path (export, renderer, passes) runs from a worker thread, as it does
on Blender's render thread in the interface."""

import ast
import inspect
import math
import os
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

from addon_support import BINARY, addon, bpy, bpy_module, cubist_binary, new_scene  # noqa: F401
from glb_support import Glb


@pytest.fixture
def export(addon):
    return sys.modules["blender_addon.export"]


@pytest.fixture
def engine(addon):
    return sys.modules["blender_addon.engine"]


@pytest.fixture
def exports(engine, tmp_path):
    folder = tmp_path / "exports"
    engine.keep_exports = folder
    yield folder
    engine.keep_exports = None


def viewport_export(bpy, export, path):
    """The exporter on the viewport's depsgraph (the main thread's; F12 uses the render's)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    stats = export.export_glb(depsgraph, path)
    return Glb(path), stats


def f12(bpy, scene, path):
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return path


def floats(collection, prop, width):
    a = np.empty(len(collection) * width, dtype=np.float32)
    collection.foreach_get(prop, a)
    return a.reshape(-1, width)


# ---------------------------------------------------------------------------------------------
# Geometry and attributes, corner by corner


def test_triangulation_is_blenders(bpy, export):
    """Triangles, quads and n-gons (a concave one too) split exactly as Blender's loop_triangles."""
    scene = new_scene(bpy)
    me = bpy.data.meshes.new("Polys")
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (3, 0.5, 0), (2, 1, 0),
             (4, 0, 0), (6, 0, 0), (6, 2, 0), (5, 0.5, 0), (4, 2, 0)]  # quad, triangle, concave hexagon
    me.from_pydata(verts, [], [(0, 1, 2, 3), (4, 5, 6), (7, 8, 9, 10, 11)])
    bpy.ops.mesh.primitive_circle_add(vertices=9, fill_type="NGON")
    bpy.ops.mesh.primitive_monkey_add()  # bent quads, split along their other diagonal
    meshes = [me, scene.objects["Circle"].data, bpy.context.object.data]
    for m in meshes:
        m.calc_loop_triangles()
        pos = floats(m.vertices, "co", 3)
        corner_vert = np.array([loop.vertex_index for loop in m.loops])
        tris, tri_poly, sizes = export.triangulate(m, len(m.polygons), len(m.loops), pos, corner_vert)
        expected = np.array([list(t.loops) for t in m.loop_triangles])
        assert np.array_equal(tris, expected), (tris, expected)
        assert np.array_equal(tri_poly, [t.polygon_index for t in m.loop_triangles])


def blender_corners(bpy, ob, uv_name=None, color_name=None):
    """Per loop triangle corner: position, corner normal, UV (v flipped), colour, material."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    me = ob.evaluated_get(depsgraph).data
    tris = np.array([list(t.loops) for t in me.loop_triangles])
    mats = np.array([t.material_index for t in me.loop_triangles])
    corner_vert = np.array([loop.vertex_index for loop in me.loops])
    pos = floats(me.vertices, "co", 3)[corner_vert]
    nrm = floats(me.corner_normals, "vector", 3)
    uv = floats(me.uv_layers[uv_name].data, "uv", 2) if uv_name else None
    if uv is not None:
        uv[:, 1] = 1 - uv[:, 1]
    col = None
    if color_name:
        attr = me.color_attributes[color_name]
        col = floats(attr.data, "color", 4)
        if attr.domain == "POINT":
            col = col[corner_vert]
    return tris, mats, pos, nrm, uv, col


def set_bools(me, name, domain, values):
    attr = me.attributes.get(name) or me.attributes.new(name, "BOOLEAN", domain)
    attr.data.foreach_set("value", values)


@pytest.mark.parametrize("shading", ["smooth", "flat", "mixed", "sharp_edges", "custom"])
def test_corners_carry_blenders_normals_uvs_and_colours(bpy, export, tmp_path, shading):
    """Every triangle corner of the GLB has the position, shading normal, UV and colour
    Blender renders with, whatever decides the normals (smooth or flat faces, both, sharp
    edges, custom normals): the welding of corners into glTF vertices loses nothing and the
    triangles keep Blender's order."""
    scene = new_scene(bpy)
    monkey = scene.objects["Suzanne"]
    me = monkey.data
    if shading == "flat":
        me.shade_flat()
    else:
        me.shade_smooth()
    if shading == "mixed":
        set_bools(me, "sharp_face", "FACE", np.arange(len(me.polygons)) % 3 == 0)
    if shading == "sharp_edges":
        set_bools(me, "sharp_edge", "EDGE", np.arange(len(me.edges)) % 7 == 0)
    if shading == "custom":
        me.normals_split_custom_set([(0.0, 0.0, 1.0)] * len(me.loops))
    expected_domain = {"smooth": "POINT", "flat": "FACE"}.get(shading, "CORNER")
    assert me.normals_domain == expected_domain
    rng = np.random.default_rng(3)
    col = me.color_attributes.new("Paint", "FLOAT_COLOR", "CORNER")
    col.data.foreach_set("color", rng.random(len(me.loops) * 4).astype(np.float32))
    # The material asks for both: an image texture times the colour attribute.
    mat = bpy.data.materials.new("Textured")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True  # always on from 5.0
    tree = mat.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.new("Checker", 8, 8)
    tex.image.generated_type = "COLOR_GRID"
    attr = tree.nodes.new("ShaderNodeVertexColor")
    attr.layer_name = "Paint"
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    mix.inputs["Factor"].default_value = 1.0
    tree.links.new(tex.outputs["Color"], mix.inputs["A_Color"] if "A_Color" in mix.inputs else mix.inputs[6])
    tree.links.new(attr.outputs["Color"], mix.inputs["B_Color"] if "B_Color" in mix.inputs else mix.inputs[7])
    tree.links.new(mix.outputs["Result"] if "Result" in mix.outputs else mix.outputs[2], bsdf.inputs["Base Color"])
    me.materials.append(mat)

    glb, _ = viewport_export(bpy, export, tmp_path / "scene.glb")
    node = next(n for n in glb.nodes_with_mesh() if n["name"] == "Suzanne")
    mesh = glb.json["meshes"][node["mesh"]]
    assert len(mesh["primitives"]) == 1
    p = glb.primitive(mesh["primitives"][0])
    tris, _mats, pos, nrm, uv, colr = blender_corners(bpy, monkey, "UVMap", "Paint")
    idx = p["indices"]
    assert idx.shape == tris.shape
    assert np.array_equal(p["POSITION"][idx], pos[tris])
    assert np.array_equal(p["NORMAL"][idx], nrm[tris])
    assert np.array_equal(p["TEXCOORD_0"][idx], uv[tris])
    assert np.array_equal(p["COLOR_0"][idx], colr[tris])
    # Welded (no unused vertex); with random corner colours only corners of one face share.
    assert len(np.unique(idx)) == len(p["POSITION"]) <= len(me.loops)
    # Bounds as declared (the renderer checks them).
    acc = glb.json["accessors"][mesh["primitives"][0]["attributes"]["POSITION"]]
    assert acc["min"] == pytest.approx(p["POSITION"].min(axis=0).tolist())
    assert acc["max"] == pytest.approx(p["POSITION"].max(axis=0).tolist())
    # The generated texture is embedded as a PNG of its pixels (sRGB bytes, rows top-down).
    image = glb.json["images"][0]
    assert image["mimeType"] == "image/png"
    png = tmp_path / "tex.png"
    png.write_bytes(glb.view_bytes(image["bufferView"]))
    pngio = sys.modules["blender_addon.pngio"]
    px = np.empty(8 * 8 * 4, np.float32)
    tex.image.pixels.foreach_get(px)
    expected = np.round(px.reshape(8, 8, 4)[::-1] * 255).astype(np.uint8)
    assert np.array_equal(pngio.read(png), expected)


def test_shared_vertices_stay_shared(bpy, export, tmp_path):
    """Without per-corner attributes (smooth, no texture, no colour) the glTF vertices are
    Blender's vertices: the renderer's mesh saliency sees the same connectivity."""
    scene = new_scene(bpy)
    me = scene.objects["Suzanne"].data
    me.shade_smooth()
    glb, _ = viewport_export(bpy, export, tmp_path / "scene.glb")
    node = next(n for n in glb.nodes_with_mesh() if n["name"] == "Suzanne")
    p = glb.primitive(glb.json["meshes"][node["mesh"]]["primitives"][0])
    assert len(p["POSITION"]) == len(me.vertices)
    assert set(p) == {"POSITION", "NORMAL", "indices"}


def test_materials_split_a_mesh_into_primitives(bpy, export, tmp_path):
    scene = new_scene(bpy)
    cube = scene.objects["Cube"]
    colours = {"Red": (0.8, 0.05, 0.05, 1.0), "Blue": (0.05, 0.1, 0.8, 1.0)}
    for name, rgba in colours.items():
        m = bpy.data.materials.new(name)
        if bpy.app.version < (5, 0, 0):
            m.use_nodes = True  # always on from 5.0
        m.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = rgba
        m.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.25
        cube.data.materials.append(m)
    cube.data.polygons.foreach_set("material_index", [0, 1, 0, 1, 0, 1])
    glb, _ = viewport_export(bpy, export, tmp_path / "scene.glb")
    node = next(n for n in glb.nodes_with_mesh() if n["name"] == "Cube")
    prims = glb.json["meshes"][node["mesh"]]["primitives"]
    assert len(prims) == 2
    for p, name in zip(prims, ("Red", "Blue")):
        mat = glb.json["materials"][p["material"]]
        assert mat["name"] == name
        assert mat["pbrMetallicRoughness"]["baseColorFactor"] == pytest.approx(colours[name])
        assert mat["pbrMetallicRoughness"]["roughnessFactor"] == pytest.approx(0.25)
        assert len(glb.primitive(p)["indices"]) == 6  # three faces, two triangles each


# ---------------------------------------------------------------------------------------------
# What F12 exports: the render's depsgraph


def test_render_levels_instances_and_visibility(bpy, engine, exports, tmp_path):
    """Through F12 (the render depsgraph): modifiers at their render levels, particle,
    geometry-nodes and collection instances sharing one glTF mesh each, curves, text and
    metaballs as meshes, objects hidden or disabled for render left out."""
    scene = new_scene(bpy)
    monkey = scene.objects["Suzanne"]
    sub = monkey.modifiers.new("Subdivision", "SUBSURF")
    sub.levels, sub.render_levels = 0, 2
    # Particles: 40 hair instances of an icosphere; the emitter plane itself not rendered.
    bpy.ops.mesh.primitive_plane_add(size=3, location=(0, 3, -1))
    plane = bpy.context.object
    bpy.ops.mesh.primitive_ico_sphere_add(radius=0.1, location=(0, 0, -20))
    ico = bpy.context.object
    ico.hide_render = True  # the instanced object itself is not rendered, its instances are
    psys = plane.modifiers.new("Hair", "PARTICLE_SYSTEM").particle_system.settings
    psys.type, psys.count, psys.render_type, psys.instance_object = "HAIR", 40, "OBJECT", ico
    plane.show_instancer_for_render = False
    # Collection instances: three of a cone.
    coll = bpy.data.collections.new("Cones")
    bpy.ops.mesh.primitive_cone_add()
    cone = bpy.context.object
    scene.collection.objects.unlink(cone)
    coll.objects.link(cone)
    for i in range(3):
        e = bpy.data.objects.new(f"Cones{i}", None)
        e.instance_type, e.instance_collection = "COLLECTION", coll
        e.location = (i - 1.0, -1.0, 1.5)
        scene.collection.objects.link(e)
    # Geometry nodes: a 3 x 2 grid of points instancing a small cube object.
    bpy.ops.mesh.primitive_cube_add(size=0.2, location=(0, 0, -20))
    small = bpy.context.object
    small.hide_render = True
    bpy.ops.mesh.primitive_plane_add(location=(-2, 0, 0))
    host = bpy.context.object
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    tree.interface.new_socket(name="Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket(name="Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    out = tree.nodes.new("NodeGroupOutput")
    grid = tree.nodes.new("GeometryNodeMeshGrid")
    grid.inputs["Vertices X"].default_value, grid.inputs["Vertices Y"].default_value = 3, 2
    iop = tree.nodes.new("GeometryNodeInstanceOnPoints")
    info = tree.nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = small
    tree.links.new(grid.outputs["Mesh"], iop.inputs["Points"])
    tree.links.new(info.outputs["Geometry"], iop.inputs["Instance"])
    tree.links.new(iop.outputs["Instances"], out.inputs[0])
    host.modifiers.new("Scatter", "NODES").node_group = tree
    # Curves, text, metaball.
    bpy.ops.curve.primitive_bezier_circle_add(location=(2, 0, 1))
    bpy.context.object.data.bevel_depth = 0.05
    bpy.ops.object.text_add(location=(-1, -1, -1))
    bpy.ops.object.metaball_add(location=(2, 2, 0))
    # Hidden for render, in a collection disabled for render, in an excluded collection; and
    # one hidden in the viewport only, which renders.
    for name, where in (("HiddenRender", "object"), ("InDisabled", "disabled"), ("InExcluded", "excluded"),
                        ("ViewportHidden", "viewport")):
        ob = bpy.data.objects.new(name, scene.objects["Cube"].data)
        if where in ("object", "viewport"):
            scene.collection.objects.link(ob)
            if where == "object":
                ob.hide_render = True
            else:
                ob.hide_viewport = True
        else:
            c = bpy.data.collections.new(name + "Coll")
            scene.collection.children.link(c)
            c.objects.link(ob)
            if where == "disabled":
                c.hide_render = True
            else:
                bpy.context.view_layer.layer_collection.children[c.name].exclude = True

    f12(bpy, scene, tmp_path / "f12.png")
    glb = Glb(exports / "frame_0001.glb")
    nodes = glb.nodes_with_mesh()
    names = [n["name"] for n in nodes]
    meshes = glb.json["meshes"]

    def instances_of(mesh_name):
        return [n for n in nodes if meshes[n["mesh"]]["name"] == mesh_name]

    # Render-level subdivision: level 2 turns each corner of the cage into 4 quads, 8 triangles.
    suzanne = next(n for n in nodes if n["name"] == "Suzanne")
    subdivided = sum(len(glb.primitive(p)["indices"]) for p in meshes[suzanne["mesh"]]["primitives"])
    assert subdivided == 8 * len(monkey.data.loops)
    ico_nodes = instances_of(ico.data.name)
    assert len(ico_nodes) == 40 and len({n["mesh"] for n in ico_nodes}) == 1, len(ico_nodes)
    cone_nodes = instances_of(cone.data.name)
    assert len(cone_nodes) == 3 and len({n["mesh"] for n in cone_nodes}) == 1
    assert {tuple(np.round(glb.node_matrix(n)[:3, 3], 5)) for n in cone_nodes} == {
        (-1.0, -1.0, 1.5), (0.0, -1.0, 1.5), (1.0, -1.0, 1.5)}
    cube_nodes = instances_of(small.data.name)
    assert len(cube_nodes) == 6 and len({n["mesh"] for n in cube_nodes}) == 1
    for kind in ("BézierCircle", "Text", "Mball"):
        assert names.count(kind) == 1, (kind, names)  # once: not also as the converted object
    for gone in ("Plane", "Icosphere", "HiddenRender", "InDisabled", "InExcluded"):
        assert gone not in names, gone
    assert "ViewportHidden" in names
    assert glb.json["meshes"].__len__() < len(nodes)  # instances share meshes


def test_camera_lights_and_world(bpy, export, engine, exports, tmp_path):
    scene = new_scene(bpy, 80, 40)
    cam = scene.camera.data
    cam.lens, cam.clip_start, cam.clip_end = 35.0, 0.2, 50.0
    for kind, energy in (("POINT", 100.0), ("SPOT", 200.0), ("AREA", 50.0)):
        light = bpy.data.objects.new(kind, bpy.data.lights.new(kind, kind))
        light.data.energy = energy
        light.location = (1.0, -2.0, 3.0)
        scene.collection.objects.link(light)
    scene.objects["SPOT"].data.spot_size, scene.objects["SPOT"].data.spot_blend = math.radians(60), 0.25
    scene.objects["Sun"].data.energy = 3.0
    f12(bpy, scene, tmp_path / "f12.png")
    glb = Glb(exports / "frame_0001.glb")
    lights = {light["name"]: light for light in glb.json["extensions"]["KHR_lights_punctual"]["lights"]}
    assert lights["Sun"]["type"] == "directional" and lights["Sun"]["intensity"] == pytest.approx(3.0 * 683)
    assert lights["POINT"]["type"] == "point"
    assert lights["POINT"]["intensity"] == pytest.approx(100.0 / (4 * math.pi) * 683)
    spot = lights["SPOT"]
    assert spot["type"] == "spot" and spot["spot"]["outerConeAngle"] == pytest.approx(math.radians(30))
    assert spot["spot"]["innerConeAngle"] == pytest.approx(math.radians(30) * 0.75)
    assert lights["AREA"]["type"] == "spot" and lights["AREA"]["spot"]["outerConeAngle"] == pytest.approx(math.pi / 2)
    # The camera: first node, Blender's position and view, the vertical field of view of a
    # 35 mm lens on a 36 mm sensor fitted horizontally at 2:1.
    first = glb.json["nodes"][glb.json["scenes"][0]["nodes"][0]]
    camera = glb.json["cameras"][first["camera"]]["perspective"]
    assert camera["yfov"] == pytest.approx(2 * math.atan(18 / 35 / 2), rel=1e-6)
    assert (camera["znear"], camera["zfar"]) == pytest.approx((0.2, 50.0))
    m = glb.node_matrix(first)
    assert m[:3, 3] == pytest.approx(list(scene.camera.location), abs=1e-6)
    assert m[:3, 2] == pytest.approx(list(scene.camera.matrix_world.col[2][:3]), abs=1e-6)  # looks down -Z
    # The light node's direction is the light's -Z.
    sun = next(n for n in glb.json["nodes"] if n.get("name") == "Sun")
    assert glb.node_matrix(sun)[:3, 2] == pytest.approx(list(scene.objects["Sun"].matrix_world.col[2][:3]), abs=1e-6)
    # The CLI renders the exported file alone (its own camera): a valid, complete scene.
    r = subprocess.run([str(BINARY), "render", str(exports / "frame_0001.glb"), "-o", str(tmp_path / "cli.png"),
                        "--width", "40", "--height", "20", "--spp", "1", "--camera", "perspective"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


# ---------------------------------------------------------------------------------------------
# The same pictures as Blender's glTF exporter gave (on the glTF samples, imported into Blender)


SAMPLES = ["Duck", "BoxTextured", "CesiumMilkTruck", "VertexColorTest", "TextureTransformTest", "MultiUVTest",
           "UnlitTest", "BoxTextured_lights", "SheenCloth"]


def shared_samples() -> Path:
    return Path(os.environ.get("CUBIST_SHARED", Path(__file__).resolve().parents[3] / "shared")) / "gltf-samples"


@pytest.mark.parametrize("name", SAMPLES)
def test_renders_like_blenders_gltf_exporter(bpy, export, tmp_path, name):
    """A sample imported into Blender, exported by this add-on and by Blender's glTF exporter
    (the add-on's former path), rendered by the CLI through the same camera: the same picture.
    (The samples' own cameras are removed: Blender's exporter writes every camera.)"""
    src = shared_samples() / f"{name}.glb"
    if not src.is_file():
        pytest.skip(f"{src} is absent (the shared test data is not part of a fresh clone)")
    from mathutils import Vector

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    bpy.ops.import_scene.gltf(filepath=str(src))
    for ob in [o for o in scene.objects if o.type == "CAMERA"]:
        bpy.data.objects.remove(ob)
    pts = [ob.matrix_world @ Vector(c) for ob in scene.objects if ob.type == "MESH" for c in ob.bound_box]
    lo = Vector([min(p[i] for p in pts) for i in range(3)])
    hi = Vector([max(p[i] for p in pts) for i in range(3)])
    centre, radius = (lo + hi) / 2, (hi - lo).length / 2
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    scene.collection.objects.link(cam)
    cam.location = centre + Vector((0.6, -2.2, 1.0)).normalized() * radius * 3
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    if not any(o.type == "LIGHT" for o in scene.objects):
        sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
        sun.rotation_euler = (0.6, 0.2, 0.4)
        scene.collection.objects.link(sun)
    viewport_export(bpy, export, tmp_path / "ours.glb")
    bpy.ops.export_scene.gltf(filepath=str(tmp_path / "gltf.glb"), export_format="GLB", use_selection=False,
                              export_cameras=True, export_lights=True, export_apply=True, export_yup=True,
                              export_texcoords=True, export_normals=True, export_materials="EXPORT",
                              export_animations=False)
    pngio = sys.modules["blender_addon.pngio"]
    pictures = []
    for which in ("ours", "gltf"):
        out = tmp_path / f"{which}.png"
        r = subprocess.run([str(BINARY), "render", str(tmp_path / f"{which}.glb"), "-o", str(out), "--preset", "plain",
                            "--camera", "perspective", "--width", "160", "--height", "120", "--spp", "2"],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        pictures.append(pngio.read(out)[..., :3].astype(np.float64))
    diff = np.abs(pictures[0] - pictures[1])
    assert diff.mean() < 0.5, f"mean difference {diff.mean():.2f}/255"
    assert (diff.max(axis=2) > 8).mean() < 0.01
    # Not an empty picture: the object covers a good part of it.
    assert (np.abs(pictures[0] - pictures[0][0, 0]).max(axis=2) > 8).mean() > 0.05


# ---------------------------------------------------------------------------------------------
# The render thread


RENDER_PATH = ("_render", "_cancelled", "_export", "_export_frame", "_run", "_layout_frame_source", "_deliver",
               "_mark", "_show_preview", "_put_picture")  # render() itself is checked with them


def test_the_render_path_uses_no_operator_context_or_scene_frame(engine, export):
    """What render() reaches never calls bpy.ops, bpy.context, temp_override or a scene's
    frame_set (only the engine's own self.frame_set), checked on the code's syntax tree."""
    pngio, runner, mapping, turns = (sys.modules[f"blender_addon.{m}"] for m in ("pngio", "runner", "mapping", "turns"))
    # turns.py's handlers run on the render thread too (render_pre, render_post).
    # The session's renderer and the picture's hand-back run there too (F12 on `cubist serve`).
    served = [sys.modules[f"blender_addon.{m}"] for m in ("serve_render", "server", "serve_client", "picture",
                                                          "frame_job")]
    sources = [inspect.getsource(m) for m in (export, pngio, runner, mapping, *served)]
    # What was rendered ahead is claimed from the render thread, and prepared on a worker thread.
    ahead = sys.modules["blender_addon.ahead"]
    sources += [inspect.getsource(f) for f in (ahead.claim, ahead.cancel, ahead.release, ahead.job_key, ahead._work,
                                               ahead._send_and_wait, ahead._remove_older)]
    sources += [inspect.getsource(f) for f in (turns._long_turns, turns._short_turns, turns.yield_turn)]
    cls = engine.CubistRenderEngine
    sources += [inspect.getsource(cls.__dict__[name]) for name in ("render", *RENDER_PATH)]
    sources += [inspect.getsource(f) for f in (engine.addon_preferences, engine.layout_folder, engine._panel,
                                               engine.region, engine._read_pass, engine._set_rect, engine._combined)]
    found = []
    for src in sources:
        for node in ast.walk(ast.parse(textwrap.dedent(src))):
            if isinstance(node, ast.Attribute):
                if isinstance(node.value, ast.Name) and node.value.id == "bpy" and node.attr in {"ops", "context"}:
                    found.append(f"bpy.{node.attr} (line {node.lineno})")
                if node.attr == "temp_override":
                    found.append(f"temp_override (line {node.lineno})")
                if node.attr == "frame_set" and not (isinstance(node.value, ast.Name) and node.value.id == "self"):
                    found.append(f"frame_set (line {node.lineno})")
    assert found == []


class _Pass:
    def __init__(self):
        self.values = None

    @property
    def rect(self):
        return self

    def foreach_set(self, values):
        self.values = np.array(values)


class _Layer:
    def __init__(self, names):
        self.passes = self
        self.by_name = {n: _Pass() for n in names}
        self.loaded = None

    def find_by_name(self, name, view):
        return self.by_name.get(name)

    def get(self, name):
        return self.by_name.get(name)

    def load_from_file(self, path, x=0, y=0):
        self.loaded = sys.modules["blender_addon.pngio"].read(path)


class _Result:
    def __init__(self, names):
        self.layers = [_Layer(names)]


class RenderThreadHost:
    """Stands in for Blender's RenderEngine around the engine's own render code (its methods,
    taken from the class), recording what it reports; `frame_set` is not expected here."""

    camera_override = None

    is_animation = False  # F12: a preview first

    def __init__(self, pass_names):
        self.pass_names = pass_names
        self.stats, self.progress, self.reports, self.result = [], [], [], None
        self.thread = None
        self._result = self._image = None  # as render() leaves them for _render
        self.updates = 0

    def update_result(self, result):
        self.updates += 1

    def update_stats(self, a, b):
        self.stats.append(b)
        self.thread = threading.current_thread()

    def update_progress(self, f):
        self.progress.append(f)

    def report(self, kind, message):
        self.reports.append((kind, message))

    def test_break(self):
        return False

    def frame_set(self, frame, subframe):
        raise AssertionError("this test renders the layout frame itself")

    def begin_result(self, x, y, w, h, layer=""):
        return _Result(self.pass_names)

    def end_result(self, result, cancel=False):
        assert not cancel
        self.result = result


def test_export_render_and_load_from_a_worker_thread(bpy, engine, exports, tmp_path):
    """The engine's render code (export, renderer, picture and passes read back) run from a
    worker thread on a depsgraph made on the main thread: Blender's interface runs render()
    on its render-job thread the same way. The picture and depth pass that come back are the
    CLI's for the exported file."""
    scene = new_scene(bpy, 64, 48)
    scene.cubist.pass_depth = True
    scene.cubist.layout_folder = str(tmp_path / "layouts")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    cls = engine.CubistRenderEngine
    host_type = type("Host", (RenderThreadHost,), {name: cls.__dict__[name] for name in RENDER_PATH})
    host = host_type(["Combined", "Cubist Depth"])
    errors = []

    def work():
        try:
            host._render(depsgraph, depsgraph.scene_eval)
        except BaseException as e:  # reported to the main thread's assertion below
            errors.append(e)

    t = threading.Thread(target=work, name="render-job")
    t.start()
    t.join(timeout=300)
    assert not t.is_alive() and errors == [], errors
    assert host.thread is t and host.result is not None, host.reports
    assert [k for k, _ in host.reports if "ERROR" in k] == []
    assert host.progress and host.progress[-1] == 1.0
    cli = tmp_path / "cli.png"
    r = subprocess.run([str(BINARY), "render", str(exports / "frame_0001.glb"), "-o", str(cli), "--config",
                        str(exports / "settings_0001.json")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    pngio = sys.modules["blender_addon.pngio"]
    layer = host.result.layers[0]
    # The preview was shown, then the picture: the CLI's, as Blender decodes a PNG.
    assert host.updates == 1
    picture = sys.modules["blender_addon.picture"]
    assert np.array_equal(layer.by_name["Combined"].values, picture.result_rect(pngio.read(cli), (0, 0, 64, 48)).reshape(-1))
    depth = layer.by_name["Cubist Depth"].values.reshape(48, 64)[::-1]  # rows bottom-up in Blender
    assert np.array_equal(depth, pngio.read(tmp_path / "cli.depth.png")[..., 0] / np.float32(255.0))
    assert depth.std() > 0.05



def _split_export_scene(bpy, level):
    """Scenes for the split export, each adding to the one before: a smooth monkey and a cube;
    several materials on a partly flat sphere, n-gons, a corner colour attribute; a texture with
    UVs on a subdivided grid, text, linked duplicates."""
    new_scene(bpy)
    if level >= 1:
        bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12, location=(-2, 1, 0))
        ob = bpy.context.object
        for i, c in enumerate([(1, 0, 0, 1), (0, 1, 0, 1), (0, 0, 1, 1)]):
            m = bpy.data.materials.new(f"m{i}")
            m.diffuse_color = c
            ob.data.materials.append(m)
        for k, p in enumerate(ob.data.polygons):
            p.material_index = k % 3 if k % 7 else 1
            p.use_smooth = k % 2 == 0
        bpy.ops.mesh.primitive_circle_add(fill_type="NGON", location=(0, 3, 0))
        bpy.ops.mesh.primitive_cylinder_add(location=(2, 3, 0))
        col = bpy.context.object.data.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
        for i, d in enumerate(col.data):
            d.color = (i % 5 / 5, 0.5, 0.2, 1.0)
    if level >= 2:
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=60, y_subdivisions=60, size=3, location=(0, 2, -1))
        grid = bpy.context.object
        grid.modifiers.new("subsurf", "SUBSURF").levels = 1
        img = bpy.data.images.new("tex", 8, 8)
        img.pixels[:] = [0.25, 0.5, 0.75, 1.0] * 64
        mat = bpy.data.materials.new("textured")
        if bpy.app.version < (5, 0, 0):
            mat.use_nodes = True
        tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
        tex.image = img
        mat.node_tree.links.new(tex.outputs["Color"], mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
        grid.data.materials.append(mat)
        bpy.ops.object.text_add(location=(0, 0, 1))
        bpy.ops.mesh.primitive_ico_sphere_add(location=(2, 2, 1))
        bpy.ops.object.duplicate_move_linked()
        bpy.context.object.location.x += 1


@pytest.mark.parametrize("level", [0, 1, 2])
def test_the_split_export_writes_the_same_file(bpy, export, tmp_path, level):
    """The viewport reads the scene on the main thread (`read_scene`) and writes it on its worker
    (`Exporter.write`): the file is export_glb's, byte for byte, and the second half reads
    nothing of Blender's (the meshes removed in between change nothing)."""
    _split_export_scene(bpy, level)
    dg = bpy.context.evaluated_depsgraph_get()
    whole, split = tmp_path / "whole.glb", tmp_path / "split.glb"
    stats = export.export_glb(dg, whole)
    exporter = export.read_scene(dg)
    exporter.depsgraph = None
    assert exporter.glb.pending  # the arrays are made later
    for ob in list(bpy.data.objects):
        if ob.type in {"MESH", "FONT"}:
            bpy.data.objects.remove(ob)
    for me in list(bpy.data.meshes):
        bpy.data.meshes.remove(me)
    bpy.context.evaluated_depsgraph_get()
    errors = []

    def write():
        try:
            exporter.write(split)
        except Exception as e:
            errors.append(e)

    worker = threading.Thread(target=write)
    worker.start()
    worker.join(60)
    assert not worker.is_alive() and not errors, errors
    assert split.read_bytes() == whole.read_bytes()
    assert (exporter.stats.triangles, exporter.stats.meshes, exporter.stats.warnings) == \
        (stats.triangles, stats.meshes, stats.warnings)
    assert stats.triangles > 0 and stats.meshes >= 2 + 3 * (level >= 1)


def test_a_superseded_split_export_stops(bpy, export, tmp_path):
    """`write` stops between arrays when asked to (a newer scene was read) and writes nothing."""
    _split_export_scene(bpy, 1)
    exporter = export.read_scene(bpy.context.evaluated_depsgraph_get())
    asked = []

    def should_cancel():
        asked.append(1)
        return len(asked) > 2

    with pytest.raises(export.ExportCancelled):
        exporter.write(tmp_path / "x.glb", should_cancel)
    assert len(asked) == 3 and not (tmp_path / "x.glb").exists()


def test_the_viewport_reuses_the_arrays_of_unchanged_meshes(bpy, export, tmp_path):
    """read_scene's mesh_cache (the viewport passes it when no update reached a mesh's data):
    objects moved, the meshes' arrays are not read again and the file is a fresh export's; a
    mesh whose data changed at the same address is read again (its key holds a few values)."""
    _split_export_scene(bpy, 1)
    first = export.read_scene(bpy.context.evaluated_depsgraph_get())
    assert first.stats.meshes_reused == 0 and len(first.meshes_read) == first.stats.meshes == 5
    bpy.data.objects["Cube"].location.x += 0.5
    dg = bpy.context.evaluated_depsgraph_get()
    again = export.read_scene(dg, mesh_cache=first.meshes_read)
    assert again.stats.meshes_reused == 5
    fresh, reused = tmp_path / "fresh.glb", tmp_path / "reused.glb"
    export.export_glb(dg, fresh)
    again.write(reused)
    assert reused.read_bytes() == fresh.read_bytes()
    # The monkey's first vertex moved, the cache given anyway: read again.
    monkey = bpy.data.objects["Suzanne"]
    monkey.data.vertices[0].co.z += 0.25
    monkey.data.update()
    dg = bpy.context.evaluated_depsgraph_get()
    third = export.read_scene(dg, mesh_cache=again.meshes_read)
    assert third.stats.meshes_reused == 4
    export.export_glb(dg, fresh)
    third.write(reused)
    assert reused.read_bytes() == fresh.read_bytes()
