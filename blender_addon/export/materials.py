"""Materials as the renderer reads them: what colours a surface in Blender's node tree (the
Principled BSDF's, a Diffuse or Emission shader's base colour, a constant, an Image Texture
with its Mapping node, a colour attribute, or a Multiply of those; `material_info`), and their
glTF materials, textures and images, each written once per export (`MaterialWriter`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Optional

import bpy

from .glb import CLAMP_TO_EDGE, LINEAR, MIRRORED_REPEAT, NEAREST, REPEAT, GlbBuilder
from .images import image_bytes

WRAP = {"REPEAT": REPEAT, "EXTEND": CLAMP_TO_EDGE, "CLIP": CLAMP_TO_EDGE, "MIRROR": MIRRORED_REPEAT}


@dataclass
class TextureInfo:
    image: object  # bpy.types.Image (original)
    uv_map: str = ""  # "" = the mesh's active render UV map
    wrap: int = REPEAT
    nearest: bool = False
    transform: Optional[dict] = None  # KHR_texture_transform


@dataclass
class MaterialInfo:
    name: str
    base_color: list
    metallic: float = 0.0
    roughness: float = 0.5
    unlit: bool = False
    texture: Optional[TextureInfo] = None
    # Colour attribute multiplying the base colour: None, or its name ("" = the render colour).
    vertex_color: Optional[str] = None
    warnings: list = field(default_factory=list)


def _source(socket):
    """(node, output socket) feeding an input socket, through reroutes; None when unlinked."""
    seen = 0
    while socket is not None and socket.is_linked and seen < 64:
        link = socket.links[0]
        if getattr(link, "is_muted", False) or not link.is_valid:
            return None
        node = link.from_node
        if node.type == "REROUTE":
            socket = node.inputs[0]
            seen += 1
            continue
        return node, link.from_socket
    return None


def _input(node, *names):
    for name in names:
        for sock in node.inputs:
            if sock.identifier == name or (sock.name == name and sock.enabled):
                return sock
    return None


@dataclass
class _Colour:
    factor: list  # linear RGBA
    texture: Optional[TextureInfo] = None
    vertex_color: Optional[str] = None
    supported: bool = True
    what: str = ""


def _colour_source(socket, depth: int = 0) -> _Colour:
    """What feeds a colour input: a constant, an Image Texture, a colour attribute, or a
    Multiply mix of those (the cases Blender's glTF exporter also recognises)."""
    if socket is None:
        return _Colour([1.0, 1.0, 1.0, 1.0])
    src = _source(socket)
    if src is None:
        v = list(socket.default_value)
        return _Colour((v + [1.0])[:4] if len(v) == 3 else v[:4])
    node, _out = src
    if node.type == "TEX_IMAGE":
        if node.image is None:
            return _Colour([1.0, 1.0, 1.0, 1.0], supported=False, what="an Image Texture without an image")
        return _Colour([1.0, 1.0, 1.0, 1.0], texture=_texture_info(node))
    if node.type == "VERTEX_COLOR":
        return _Colour([1.0, 1.0, 1.0, 1.0], vertex_color=node.layer_name)
    if node.type == "ATTRIBUTE" and getattr(node, "attribute_type", "GEOMETRY") == "GEOMETRY":
        return _Colour([1.0, 1.0, 1.0, 1.0], vertex_color=node.attribute_name)
    if node.type in {"MIX", "MIX_RGB"} and depth < 4:
        if node.type == "MIX":
            if getattr(node, "data_type", "RGBA") != "RGBA":
                return _Colour([1.0] * 4, supported=False, what=f"a {node.bl_label} node")
            fac, a, b = _input(node, "Factor_Float", "Factor"), _input(node, "A_Color"), _input(node, "B_Color")
        else:
            fac, a, b = _input(node, "Fac"), _input(node, "Color1"), _input(node, "Color2")
        if (node.blend_type == "MULTIPLY" and fac is not None and not fac.is_linked
                and abs(fac.default_value - 1.0) < 1e-6 and a is not None and b is not None):
            ca, cb = _colour_source(a, depth + 1), _colour_source(b, depth + 1)
            if ca.supported and cb.supported and not (ca.texture and cb.texture) and not (
                    ca.vertex_color is not None and cb.vertex_color is not None):
                return _Colour([x * y for x, y in zip(ca.factor, cb.factor)], ca.texture or cb.texture,
                               ca.vertex_color if ca.vertex_color is not None else cb.vertex_color)
    return _Colour([1.0, 1.0, 1.0, 1.0], supported=False, what=f"a {node.bl_label} node")


def _texture_info(node) -> TextureInfo:
    info = TextureInfo(image=getattr(node.image, "original", node.image) or node.image,
                       wrap=WRAP.get(node.extension, REPEAT), nearest=node.interpolation == "Closest")
    src = _source(node.inputs.get("Vector"))
    if src is not None and src[0].type == "MAPPING":
        info.transform = _texture_transform(src[0])
        src = _source(src[0].inputs.get("Vector"))
    if src is not None and src[0].type == "UVMAP":
        info.uv_map = src[0].uv_map
    return info


def _texture_transform(mapping) -> Optional[dict]:
    """A Point-type Mapping node (its z rotation and x/y scale and location) as
    KHR_texture_transform. glTF's v runs down the image (v = 1 - v_Blender): conjugating the
    node's affine map by that flip keeps rotation and scale and moves the offset."""
    if mapping.vector_type != "POINT":
        return None
    loc, rot, scale = (mapping.inputs.get(k) for k in ("Location", "Rotation", "Scale"))
    if any(s is None or s.is_linked for s in (loc, rot, scale)):
        return None
    tx, ty = loc.default_value[0], loc.default_value[1]
    r = rot.default_value[2]
    sx, sy = scale.default_value[0], scale.default_value[1]
    c, s = math.cos(r), math.sin(r)
    b, e = -s * sy, c * sy  # the node's map: u' = c sx u - s sy v + tx, v' = s sx u + c sy v + ty
    return {"offset": [tx + b, 1.0 - e - ty], "rotation": r, "scale": [sx, sy]}


# Shaders that give a surface its colour, in order of preference when Mix/Add Shader nodes
# combine several (Blender's glTF importer makes unlit materials as Transparent + Emission).
COLOUR_SHADERS = ("BSDF_PRINCIPLED", "BSDF_DIFFUSE", "EMISSION", "BACKGROUND")
NO_COLOUR_SHADERS = {"BSDF_TRANSPARENT", "HOLDOUT", "MIX_SHADER", "ADD_SHADER"}


def _surface_shader(tree):
    """The shader node that colours the surface: the one feeding the active Material Output,
    or through Mix/Add Shader nodes the preferred of the shaders they combine."""
    out = None
    get_output = getattr(tree, "get_output_node", None)
    if get_output is not None:
        for target in ("ALL", "CYCLES", "EEVEE"):
            try:
                out = get_output(target)
            except TypeError:
                out = None
            if out is not None:
                break
    if out is None:
        out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"), None)
    if out is None:
        return None
    leaves, stack, visited = [], [out.inputs.get("Surface")], 0
    while stack and visited < 64:
        visited += 1
        src = _source(stack.pop())
        if src is None:
            continue
        node = src[0]
        if node.type in {"MIX_SHADER", "ADD_SHADER"}:
            stack.extend(reversed([s for s in node.inputs if s.type == "SHADER"]))
        else:
            leaves.append(node)
    for kind in COLOUR_SHADERS:
        found = next((n for n in leaves if n.type == kind), None)
        if found is not None:
            return found
    return next((n for n in leaves if n.type not in NO_COLOUR_SHADERS), None)


def material_info(mat) -> MaterialInfo:
    """What the renderer takes from a material: the Principled BSDF's (or a Diffuse / Emission
    shader's) base colour with its texture or colour attribute, metallic, roughness. A base
    colour made by other nodes falls back to the material's viewport colour, with a warning."""
    name = mat.name
    viewport = list(mat.diffuse_color)
    info = MaterialInfo(name=name, base_color=viewport, metallic=float(mat.metallic),
                        roughness=float(mat.roughness))
    tree = mat.node_tree if (bpy.app.version >= (5, 0, 0) or mat.use_nodes) else None
    if tree is None:
        return info
    shader = _surface_shader(tree)
    if shader is None:
        return info
    if shader.type == "EMISSION" or shader.type == "BACKGROUND":
        info.unlit = True
    colour_input = _input(shader, "Base Color", "Color")
    if colour_input is None:
        info.warnings.append(f"material '{name}': its {shader.bl_label} shader has no colour: viewport colour used")
        return info
    colour = _colour_source(colour_input)
    if not colour.supported:
        info.warnings.append(f"material '{name}': base colour from {colour.what}: its viewport colour is used")
        return info
    alpha = _input(shader, "Alpha")
    if alpha is not None and not alpha.is_linked:
        colour.factor[3] *= float(alpha.default_value)
    info.base_color = colour.factor
    info.texture = colour.texture
    info.vertex_color = colour.vertex_color
    for key in ("Metallic", "Roughness"):
        sock = _input(shader, key)
        if sock is not None:
            # Linked (a texture): glTF's factor 1, as Blender's exporter writes it beside the
            # texture the renderer does not read.
            setattr(info, key.lower(), 1.0 if sock.is_linked else float(sock.default_value))
    return info


class MaterialWriter:
    """The GLB's materials, textures (sampler + image) and images: each written once per
    export, however many meshes use it. `warn` collects what the renderer will not see."""

    def __init__(self, glb: GlbBuilder, warn: Callable[[str], None]):
        self.glb = glb
        self.warn = warn
        self.infos: dict = {}  # material -> MaterialInfo
        self.material_index: dict = {}  # material -> glTF material index
        self.texture_index: dict = {}  # (image, wrap, nearest) -> glTF texture index
        self.image_index: dict = {}  # image -> glTF image index

    def info(self, mat) -> Optional[MaterialInfo]:
        if mat is None:
            return None
        key = mat.as_pointer()
        if key not in self.infos:
            info = material_info(mat)
            for w in info.warnings:
                self.warn(w)
            self.infos[key] = info
        return self.infos[key]

    def material(self, mat) -> Optional[int]:
        """The glTF material index of a Blender material (None: no material)."""
        if mat is None:
            return None
        key = mat.as_pointer()
        if key in self.material_index:
            return self.material_index[key]
        info = self.info(mat)
        pbr = {"baseColorFactor": [float(min(max(c, 0.0), 1.0)) for c in info.base_color],
               "metallicFactor": float(min(max(info.metallic, 0.0), 1.0)),
               "roughnessFactor": float(min(max(info.roughness, 0.0), 1.0))}
        if info.texture is not None:
            tex = self.texture(info.texture)
            if tex is not None:
                ref = {"index": tex}
                if info.texture.transform is not None:
                    ref["extensions"] = {"KHR_texture_transform": info.texture.transform}
                    self.glb.use_extension("KHR_texture_transform")
                pbr["baseColorTexture"] = ref
        item = {"name": info.name, "pbrMetallicRoughness": pbr}
        if info.unlit:
            item["extensions"] = {"KHR_materials_unlit": {}}
            self.glb.use_extension("KHR_materials_unlit")
        self.material_index[key] = self.glb.add("materials", item)
        return self.material_index[key]

    def texture(self, t: TextureInfo) -> Optional[int]:
        key = (t.image.as_pointer(), t.wrap, t.nearest)
        if key in self.texture_index:
            return self.texture_index[key]
        src = self.image(t.image)
        index = None
        if src is not None:
            sampler = self.glb.add("samplers", {"wrapS": t.wrap, "wrapT": t.wrap,
                                                "magFilter": NEAREST if t.nearest else LINEAR})
            index = self.glb.add("textures", {"source": src, "sampler": sampler})
        self.texture_index[key] = index
        return index

    def image(self, img) -> Optional[int]:
        key = img.as_pointer()
        if key in self.image_index:
            return self.image_index[key]
        data, mime = image_bytes(img, self.warn)
        index = None
        if data is not None:
            index = self.glb.add("images", {"name": img.name, "mimeType": mime,
                                            "bufferView": self.glb.view(data)})
        self.image_index[key] = index
        return index
