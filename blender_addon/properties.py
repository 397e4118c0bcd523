"""The Cubist settings of a scene (`scene.cubist`): one property per renderer setting, built
when the add-on registers from what the renderer says of its settings (schema.py,
`cubist settings --schema`): type, default, range, choices and tooltip. This module adds only
what is Blender's business: the properties that map Blender's scene onto settings (camera
lens and focus, world colour, layouts across frames, the saliency cache folder), labels,
slider ranges and display units, tooltips that give the schema's range and unit, an Auto
checkbox per setting the renderer may choose, and the presets' pictures as their icons.
mapping.settings_from_panel turns the properties into the settings JSON."""

import sys
from pathlib import Path

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty, StringProperty

from . import panel_layout, presets, schema
from .presets import DEFAULTS

D = DEFAULTS

# Labels where the key's words are not the panel's.
LABELS = {
    "spp": "Samples", "facet_count": "Facets", "patch_count": "Patches", "weight_colour": "Colour",
    "weight_normal": "Normal", "weight_depth": "Depth", "weight_object": "Object", "weight_saliency": "Saliency",
    "neighborhood": "Neighbourhood", "facet_projection": "Facet Rays", "facet_fov": "Facet FOV", "colors": "Colours",
    "pass_facet_ids": "Facet Index",
}
# Slider ranges (the renderer's hard limits are the properties' min and max).
SOFT = {
    "spp": (None, 64), "exposure": (None, 4.0), "facet_count": (None, 2000),
    "grid_cells": (None, 400), "patch_count": (None, 1000), "occlusion": (None, 10.0), "superpixels": (None, 5000),
    "weight_colour": (None, 4.0), "weight_normal": (None, 4.0), "weight_depth": (None, 4.0),
    "weight_saliency": (None, 4.0), "discontinuity": (None, 400.0), "neighborhood": (None, 200.0),
    "border_width": (None, 50.0), "silhouette_width": (None, 50.0), "contour_width": (None, 20.0), "colors": (None, 64),
    "stroke_length": (2.0, 80.0), "stroke_width": (1.0, 30.0),
    "background": (None, 1.0),
}
# An open bound (the renderer refuses the bound itself) is kept this far inside it.
OPEN_BOUND_STEP = 0.01
# Blender's integer properties are 32-bit.
INT_MAX = 2**31 - 1


def _update_passes(self, context):
    # Pass toggles change the passes Blender offers to the compositor.
    if context is not None and context.view_layer is not None:
        context.view_layer.update_render_passes()


def apply_look(props, values: dict) -> None:
    """Sets panel values, the preset first (its update sets the whole look)."""
    if "preset" in values:
        props.preset = values["preset"]
    for k, v in values.items():
        if k != "preset":
            setattr(props, k, v)


def _update_preset(self, context):
    # Choosing a preset sets every look value to the renderer's own (renderer_presets.json);
    # sampling, passes, files and the scene's choices stay.
    values = presets.renderer_preset_values(presets.enum_value(self.preset))
    for k, v in values.items():
        if k != "preset":
            setattr(self, k, v)


def _label(key: str) -> str:
    return LABELS.get(key) or schema.label(key.removeprefix("pass_"))


def _bounds(field: dict, kind: str) -> dict:
    """min/max (and soft limits) of a numeric property from the schema's range."""
    out: dict = {}
    key = field["key"]
    if "min" in field:
        lo = field["min"]
        # A nullable number's 0 is the panel's "automatic" (sent as null).
        if field["min_exclusive"] and not field["nullable"]:
            lo = lo + (1 if kind == "int" else OPEN_BOUND_STEP)
        out["min"] = lo
        hi = field.get("max")
        if hi is not None:
            if field["max_exclusive"]:
                hi = hi - (1 if kind == "int" else OPEN_BOUND_STEP)
            out["max"] = hi
    if kind == "int":
        out = {k: max(-INT_MAX, min(INT_MAX, int(v))) for k, v in out.items()}
    soft_lo, soft_hi = SOFT.get(key, (None, None))
    if soft_lo is not None:
        out["soft_min"] = soft_lo
    if soft_hi is not None:
        out["soft_max"] = soft_hi
    return out


def _setting_property(key: str):
    """The property of settings key `key`, from its schema entry and the panel's default."""
    f = schema.SETTINGS[key]
    kind, common = f["type"], {"name": _label(key), "description": panel_layout.tooltip(f), "default": D[key]}
    if key == "preset":
        # With each preset's picture as its icon (the panel's grid of previews).
        items = [(presets.enum_id(name), label, desc, _preset_icon(name), i)
                 for i, (name, (label, desc)) in enumerate(presets.PRESET_LABELS.items())]
        return EnumProperty(items=items, update=_update_preset, **common)
    if kind == "enum":
        items = [(presets.enum_id(v), schema.label(v), h) for v, h in schema.choices(key)]
        return EnumProperty(items=items, **common)
    if kind == "boolean":
        return BoolProperty(**common)
    if kind == "integer":
        return IntProperty(**common, **_bounds(f, "int"))
    if kind == "number":
        extra = _bounds(f, "float")
        if f["unit"] == "scene units":
            extra["unit"] = "LENGTH"
        if extra.get("min") == 0.0 and extra.get("max") == 1.0:
            extra["subtype"] = "FACTOR"
        if f["unit"] == "deg":
            extra["precision"] = 1
        return FloatProperty(**common, **extra)
    if kind == "path":
        return StringProperty(subtype="FILE_PATH", **common)
    if kind == "array" and f.get("length") == 3:
        return FloatVectorProperty(subtype="COLOR", size=3, **common, **_bounds(f, "float"))
    if kind == "array":
        # Lists are typed as text, "5, 30, 120" (mapping parses them).
        return StringProperty(**common)
    raise TypeError(f"setting {key}: type {kind} has no panel property")


def _addon_properties() -> dict:
    """Properties of the add-on's own: how Blender's scene maps onto settings."""
    return {
        "animate_seed": BoolProperty(
            name="Animated Seed", description="Add the frame number to the seed. Off (recommended for animation): "
            "what does not move stays identical between frames", default=D["animate_seed"]),
        "use_camera_lens": BoolProperty(
            name="Use Camera Lens", description="Perspective: the Blender camera's field of view instead of "
            "Ambiguity. Orthographic: its Orthographic Scale", default=D["use_camera_lens"]),
        "use_camera_focus": BoolProperty(
            name="Use Camera Focus", description="The focal centre is the camera's depth-of-field focus: its "
            "Focus Object, else its Focus Distance when Depth of Field is enabled. Off, or neither set: Framing "
            "decides", default=D["use_camera_focus"]),
        "use_world_background": BoolProperty(
            name="World Background", description="The World's colour (its Background node, times strength) as "
            "the background; off: the colour below", default=D["use_world_background"]),
        "static_facets": BoolProperty(
            name="Static Facets", description="Compute the facet layout once, on the Layout Frame, save it in the "
            "layout folder and reuse it for every frame (thesis Ch. 6; Facet Motion decides whether facets stay "
            "on the image or follow the scene). A Segment or planes layout is computed again when what the Layout "
            "Frame shows changes. Frame chunks rendered by separate processes or farm machines then match one run. "
            "Off: a new layout for every render (Facet Motion Static only)",
            default=D["static_facets"]),
        "layout_frame": IntProperty(
            name="Layout Frame", description="The frame whose view computes the static facet layout. Every frame, "
            "and every farm chunk whatever its frame range, reuses this frame's layout", default=D["layout_frame"]),
        "layout_folder": StringProperty(
            name="Layout Folder", description="Where the facet layout and the saliency cache are kept. Empty: a "
            "'cubist' folder beside the .blend (share it with the render farm)", subtype="DIR_PATH",
            default=D["layout_folder"]),
        "layout_file": StringProperty(
            name="Layout File", description="Load this facet layout (.json or .png, e.g. saved by `cubist render "
            "--save-facets` or `cubist facets`) for every frame instead of computing one. Empty: computed "
            "(once, with Static Facets)", subtype="FILE_PATH", default=D["layout_file"]),
        "use_saliency_cache": BoolProperty(
            name="Saliency Cache", description="Keep each mesh's saliency on disk, keyed by its content: frames and "
            "farm machines compute a mesh's saliency once (the picture is the same either way)",
            default=D["use_saliency_cache"]),
        "saliency_cache": StringProperty(
            name="Cache Folder", description="Where the saliency cache is kept. Empty: 'saliency' in the Layout "
            "Folder", subtype="DIR_PATH", default=D["saliency_cache"]),
    }


def _pass_properties() -> dict:
    """One toggle per render pass the renderer offers."""
    out = {}
    for toggle, name in presets.PASS_TOGGLES.items():
        help_ = dict(schema.choices("passes"))[name]
        out[toggle] = BoolProperty(name=_label(toggle), description=f"{help_} (pass '{name}')", default=D[toggle],
                                   update=_update_passes)
    return out


def _auto_properties() -> dict:
    """An "Auto" checkbox per setting the renderer may choose (panel_layout.AUTO_KEYS), computed
    from the value itself (0 = Auto, sent as null): ticking it sets 0, unticking it sets what the
    last render chose (else panel_layout.MANUAL_START), so presets and files keep one value."""
    out = {}
    for key in panel_layout.AUTO_KEYS:
        get, set_ = _auto_accessors(key)
        out[panel_layout.auto_toggle(key)] = BoolProperty(
            name="Auto", get=get, set=set_,
            description=f"Let the renderer choose {_label(key)}: "
                        f"{schema.SETTINGS[key].get('null_means') or 'per scene'}")
    return out


def _auto_accessors(key: str):
    def get(self):
        return getattr(self, key) == 0.0

    def set_(self, value):
        if value:
            setattr(self, key, 0.0)
        elif getattr(self, key) == 0.0:
            chosen = chosen_values().get(key)
            setattr(self, key, chosen if chosen else panel_layout.MANUAL_START.get(key, 1.0))

    return get, set_


def chosen_values() -> dict:
    """What the last render's renderer chose for the Auto settings ({key: value}), when the
    engine passed it on (engine.last_run['chosen']); empty otherwise."""
    engine = sys.modules.get(__package__ + ".engine")
    last = getattr(engine, "last_run", None) or {}
    chosen = last.get("chosen")
    return dict(chosen) if isinstance(chosen, dict) else {}


# Preset pictures (previews/<preset>.png) as icons: loaded once when the add-on registers.
PREVIEWS_DIR = Path(__file__).resolve().parent / "previews"
_previews = None


def _preset_icon(name: str) -> int:
    """The icon id of preset `name`'s picture (0, no icon, when it is missing)."""
    if _previews is None:
        return 0
    path = PREVIEWS_DIR / f"{name}.png"
    if name not in _previews and path.is_file():
        _previews.load(name, str(path), "IMAGE")
    return _previews[name].icon_id if name in _previews else 0


def settings_class():
    """The PropertyGroup of every panel value, in the panel's order (presets.DEFAULTS), and
    the Auto checkboxes."""
    addon, passes = _addon_properties(), _pass_properties()
    annotations = {}
    for key in DEFAULTS:
        if key in addon:
            annotations[key] = addon[key]
        elif key in passes:
            annotations[key] = passes[key]
        else:
            annotations[key] = _setting_property(key)
    annotations.update(_auto_properties())
    namespace = {"__annotations__": annotations, "__module__": __name__, "__doc__": "The Cubist settings of a scene"}
    return type("CubistSettings", (bpy.types.PropertyGroup,), namespace)


PANEL_KEYS = tuple(DEFAULTS)


def panel_values(props) -> dict:
    """The panel's values as plain Python (enum identifiers, tuples for colours)."""
    out = {}
    for k in PANEL_KEYS:
        v = getattr(props, k)
        if k == "background":
            v = tuple(v)
        out[k] = v
    return out


classes: tuple = ()


def register():
    global classes, _previews
    import bpy.utils.previews

    _previews = bpy.utils.previews.new()
    classes = (settings_class(),)
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.cubist = bpy.props.PointerProperty(type=classes[0], name="Cubist")


def unregister():
    global _previews
    del bpy.types.Scene.cubist
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
    if _previews is not None:
        bpy.utils.previews.remove(_previews)
        _previews = None
