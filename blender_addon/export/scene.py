"""The scene around the meshes: what is rendered at all (geometry, the camera the frame is
seen through), the facts mapping.py turns into settings (size, camera, world colour), and the
glTF camera and lights (KHR_lights_punctual, in the units of Blender's glTF exporter)."""

from __future__ import annotations

import math
from typing import Optional

import bpy

from ..mapping import CameraFacts, SceneFacts, render_size

GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}

# Blender's glTF exporter's photometric conversion (lighting mode "Standard"): W -> lm.
WATTS_TO_LUMENS = 683.0


def world_background(world):
    """The world's background colour in linear RGB (the Background node feeding the World
    Output, times its strength; else the world's viewport colour), or None without a world."""
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


def camera_facts(cam_obj) -> CameraFacts:
    """The evaluated camera object's frame, lens and focus (at the depsgraph's frame)."""
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


def scene_camera(depsgraph, camera_override=None):
    """The evaluated camera the frame is rendered through (camera markers already applied)."""
    cam = camera_override if camera_override is not None else depsgraph.scene_eval.camera
    if cam is None:
        return None
    return cam.evaluated_get(depsgraph)


def scene_facts(depsgraph, camera_override=None) -> SceneFacts:
    """Size, frame, camera and world of the depsgraph's evaluated scene."""
    scene = depsgraph.scene_eval
    r = scene.render
    w, h = render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    cam = scene_camera(depsgraph, camera_override)
    return SceneFacts(
        width=w,
        height=h,
        frame=scene.frame_current,
        camera=camera_facts(cam) if cam is not None else None,
        background=world_background(scene.world),
        transparent=r.film_transparent,
    )


def has_geometry(depsgraph) -> bool:
    """Whether anything visible renders as triangles (meshes, curves, text, metaballs...)."""
    for inst in depsgraph.object_instances:
        if inst.object.type in GEOMETRY_TYPES:
            return True
    return False


def light_item(data, matrix) -> Optional[dict]:
    """A Blender light as a KHR_lights_punctual light, in the units of Blender's glTF exporter
    (sun: W/m2 -> lux, x683; point and spot: W -> cd, /4pi x683). Area lights, which glTF lacks
    (the exporter drops them), become a spot lighting the half-space in front of them. None:
    a kind glTF cannot carry."""
    kind = data.type
    color = [float(c) for c in data.color]
    if getattr(data, "use_temperature", False):
        color = [c * t for c, t in zip(color, data.temperature_color)]
    energy = float(data.energy)
    if hasattr(data, "normalize") and not data.normalize and hasattr(data, "area"):
        energy *= data.area(world_matrix=matrix)
    energy *= 2.0 ** float(getattr(data, "exposure", 0.0))
    item: dict = {"name": data.name, "color": color}
    if kind == "SUN":
        item["type"] = "directional"
        item["intensity"] = energy * WATTS_TO_LUMENS
    elif kind in {"POINT", "SPOT", "AREA"}:
        item["intensity"] = energy / (4.0 * math.pi) * WATTS_TO_LUMENS
        if kind == "POINT":
            item["type"] = "point"
        else:
            if kind == "SPOT":
                outer = min(float(data.spot_size) * 0.5, math.pi / 2)
                inner = outer - outer * float(data.spot_blend)
            else:
                outer, inner = math.pi / 2, 0.0
            inner = min(max(inner, 0.0), outer * (1.0 - 1e-6))
            item["type"] = "spot"
            item["spot"] = {"innerConeAngle": inner, "outerConeAngle": outer}
    else:
        return None
    return item


def camera_item(cam, scene) -> dict:
    """The evaluated camera object as a glTF camera, at the scene's render size."""
    r = scene.render
    w, h = render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    facts = camera_facts(cam)
    data = cam.data
    znear = max(float(data.clip_start), 1e-6)
    zfar = max(float(data.clip_end), znear * 2.0)
    if data.type == "ORTHO":
        ymag = facts.ortho_height(w, h) / 2.0
        return {"name": data.name, "type": "orthographic",
                "orthographic": {"xmag": ymag * w / h, "ymag": ymag, "znear": znear, "zfar": zfar}}
    yfov = math.radians(facts.vertical_fov_deg(w, h))
    return {"name": data.name, "type": "perspective",
            "perspective": {"yfov": min(max(yfov, 1e-4), math.pi - 1e-4), "aspectRatio": w / h,
                            "znear": znear, "zfar": zfar}}
