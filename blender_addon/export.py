"""Exports what the renderer needs from Blender: the evaluated scene as a binary glTF (meshes
with modifiers applied, materials, cameras, lights; no animation data) and the plain facts
(size, camera, world colour) mapping.py turns into settings."""

from pathlib import Path

import bpy

from .mapping import CameraFacts, SceneFacts, render_size


def export_glb(scene, view_layer, frame: int, path: Path) -> Path:
    """Writes `scene` at `frame` to `path` (.glb).

    TOOLCHAIN.md's animation gotcha: during Render Animation the exporter saw a stale frame
    unless the scene is set to the frame first *and* the exporter is told to use the current
    frame, so both are done here."""
    scene.frame_set(frame)
    override = {"scene": scene}
    if view_layer is not None:
        override["view_layer"] = view_layer
    with bpy.context.temp_override(**override):
        result = bpy.ops.export_scene.gltf(
            filepath=str(path),
            check_existing=False,
            export_format="GLB",
            use_selection=False,
            use_renderable=True,
            use_active_scene=True,
            export_cameras=True,
            export_lights=True,
            export_apply=True,
            export_yup=True,
            export_texcoords=True,
            export_normals=True,
            export_materials="EXPORT",
            export_animations=False,
            export_current_frame=True,
            export_extras=False,
            will_save_settings=False,
        )
    if "FINISHED" not in result or not path.is_file():
        raise RuntimeError(f"glTF export of scene '{scene.name}' failed")
    return path


def world_background(scene):
    """The world's background colour in linear RGB (the Background node feeding the World
    Output, times its strength; else the world's viewport colour), or None without a world."""
    world = scene.world
    if world is None:
        return None
    # Blender 5 always renders the world's nodes (`use_nodes` is deprecated); 4.x only when on.
    uses_nodes = bpy.app.version >= (5, 0, 0) or world.use_nodes
    tree = world.node_tree if uses_nodes else None
    if tree is not None:
        out = next((n for n in tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
        if out is None:
            out = next((n for n in tree.nodes if n.type == "OUTPUT_WORLD"), None)
        surface = out.inputs.get("Surface") if out is not None else None
        if surface is not None and surface.is_linked:
            node = surface.links[0].from_node
            if node.type == "BACKGROUND":
                color, strength = node.inputs["Color"], node.inputs["Strength"]
                if not color.is_linked:
                    k = strength.default_value if not strength.is_linked else 1.0
                    return [c * k for c in color.default_value[:3]]
    return list(world.color[:3])


def camera_facts(scene) -> CameraFacts:
    cam_obj = scene.camera
    data = cam_obj.data
    focus_loc = None
    dof = data.dof
    if dof.focus_object is not None:
        focus_loc = list(dof.focus_object.matrix_world.translation)
    return CameraFacts(
        matrix_world=[list(r) for r in cam_obj.matrix_world],
        type=data.type,
        lens=data.lens,
        sensor_width=data.sensor_width,
        sensor_height=data.sensor_height,
        sensor_fit=data.sensor_fit,
        ortho_scale=data.ortho_scale,
        use_dof=dof.use_dof,
        focus_distance=dof.focus_distance,
        focus_object_location=focus_loc,
    )


def scene_facts(scene, frame: int) -> SceneFacts:
    """Call after export_glb set the frame, so the camera is read at that frame."""
    r = scene.render
    w, h = render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    return SceneFacts(
        width=w,
        height=h,
        frame=frame,
        camera=camera_facts(scene) if scene.camera is not None else None,
        background=world_background(scene),
        transparent=r.film_transparent,
    )


def has_geometry(depsgraph) -> bool:
    """Whether anything visible renders as triangles (meshes, curves, text, metaballs...)."""
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type in {"MESH", "CURVE", "SURFACE", "FONT", "META"}:
            return True
    return False
