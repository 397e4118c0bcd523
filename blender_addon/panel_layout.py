"""Where each value sits in the Cubist panels, as data (no bpy): ui.py draws every panel from
this and the settings schema, with no line of its own per setting.

A panel shows one or more of the schema's groups; within a group the values come in the
schema's order of its settings keys, each add-on property after the key it belongs with
(presets.ADDON_AFTER), the pass toggles in place of `passes`, and, for a key Blender decides,
the Blender property that decides it. What is not order is said per key below: when a value is
shown at all, when it is greyed out, a heading, and the keys the renderer may choose itself
("Auto"). A new renderer setting appears in its group's panel with nothing to add here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from . import presets, schema


@dataclass(frozen=True)
class Panel:
    ident: str  # CUBIST_PT_<ident>
    label: str
    groups: tuple  # schema groups, in the order drawn
    parent: Optional[str] = None  # another panel's ident
    closed: bool = False  # DEFAULT_CLOSED


# The sub-panels of the Cubist panel, in the order Blender lists them. The `Settings` group
# (the preset) is the Cubist panel's own; `Security` holds only a key Blender decides.
PANELS = (
    Panel("camera", "Camera", ("Camera",)),
    Panel("facets", "Facets", ("Facets", "Animation")),
    Panel("imprecision", "Spatial Imprecision", ("Spatial imprecision",)),
    Panel("saliency", "Mesh Saliency", ("Saliency",), parent="imprecision", closed=True),
    Panel("painterly", "Painterly", ("Painterly effects",)),
    Panel("sampling", "Sampling", ("Image",)),
    Panel("passes", "Passes", ("Outputs",), closed=True),
    Panel("output", "Output", ("Shading",)),
)
ROOT_GROUPS = ("Settings",)

# Keys Blender decides that the panel shows as the Blender property deciding them, and Blender
# properties shown after a key: (data path from the scene, property, label).
BLENDER_PROPERTY = {"transparent": ("render", "film_transparent", "Transparent")}
# The render thread reads the scene Blender evaluated for the render; Lock Interface also keeps
# the interface from editing the scene while a frame renders.
BLENDER_AFTER = {"exposure": ("render", "use_lock_interface", None)}


def _faceting(*kinds):
    return lambda c, scene: c.faceting in kinds


def _animated(c, scene) -> bool:
    return c.faceting != "NONE" and not c.layout_file


# When a value is shown at all (always, when not listed).
SHOWN: dict = {
    "use_camera_lens": lambda c, scene: c.camera in {"PERSPECTIVE", "ORTHOGRAPHIC"},
    "ambiguity": lambda c, scene: c.camera != "ORTHOGRAPHIC" and not (c.camera == "PERSPECTIVE" and c.use_camera_lens),
    "camera_size": lambda c, scene: c.camera in {"PLANAR", "CYLINDRICAL", "ORTHOGRAPHIC"},
    "facet_map": _faceting("CONSTANT"),
    "facet_count": _faceting("VORONOI"),
    "grid_cells": _faceting("VORONOI"),
    "patch_count": _faceting("PATCH"),
    "occlusion": _faceting("PATCH"),
    "planes": _faceting("PLANES"),
    "plane_detail": _faceting("PLANES"),
    "plane_outlines": _faceting("PLANES"),
    **{k: _faceting("SEGMENT") for k in ("segments", "thresholds", "superpixels", "weight_colour", "weight_normal",
                                         "weight_depth", "weight_object", "weight_saliency")},
    "facet_motion": lambda c, scene: c.faceting != "NONE",
    "static_facets": _animated,
    "layout_frame": _animated,
    "layout_folder": _animated,
    "facet_fov": lambda c, scene: c.facet_projection == "LINEAR",
}

# When a shown value is greyed out (it then has no effect).
ACTIVE: dict = {
    "fill": lambda c, scene: c.framing != "CENTRE",  # automatic framing (compose, fit) fills the view
    "static_facets": lambda c, scene: c.facet_motion != "FOLLOW",  # facets that follow always share a layout
    "layout_frame": lambda c, scene: c.static_facets or c.facet_motion == "FOLLOW",
    "layout_folder": lambda c, scene: c.static_facets or c.facet_motion == "FOLLOW",
    "saliency_cache": lambda c, scene: c.use_saliency_cache,
    "background": lambda c, scene: not c.use_world_background or scene.world is None,
}
# A whole group greyed out.
GROUP_ACTIVE: dict = {"Spatial imprecision": lambda c, scene: c.faceting != "NONE"}

# A heading over a run of values: key -> (heading, how many values from it).
HEADINGS = {"weight_colour": ("Affinity", 5), "pass_saliency": ("Include", len(presets.PASS_TOGGLES))}

# Settings the renderer chooses per scene when they are null (the panel's 0): shown as "Auto",
# with what the last render chose when the renderer reported it, or as a value once unticked.
AUTO_KEYS = tuple(k for k, f in schema.SETTINGS.items() if f["nullable"] and f["type"] == "number"
                  and k not in presets.BLENDER_KEYS)
# The value a setting starts from when Auto is unticked and no render reported its choice.
MANUAL_START = {"ambiguity": 140.0, "fill": 0.9, "camera_size": 4.0}


# What a setting means in Blender, after the renderer's own help.
BLENDER_HELP = {
    "facet_motion": ". Every frame (F12, Render Animation, a farm chunk) carries its facets from the Layout "
    "Frame's, saved in the Layout Folder with the layout; the scene must keep the Layout Frame's meshes "
    "(the same triangle count) in every frame",
}


def _number(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _range(field: dict) -> str:
    """The schema's range and unit in words: 'from 0 to 360 deg', 'above 0, up to 1'."""
    lo, hi = field.get("min"), field.get("max")
    unit = f" {field['unit']}" if field.get("unit") else ""
    if lo is None and hi is None:
        return f"in {unit.strip()}" if unit else ""
    if lo is None:
        return f"{'below' if field['max_exclusive'] else 'up to'} {_number(hi)}{unit}"
    if hi is None or hi >= 1e9:
        return f"{'above' if field['min_exclusive'] else 'at least'} {_number(lo)}{unit}"
    if field["min_exclusive"] or field["max_exclusive"]:
        low = f"{'above' if field['min_exclusive'] else 'from'} {_number(lo)}"
        high = f"{'below' if field['max_exclusive'] else 'up to'} {_number(hi)}"
        return f"{low}, {high}{unit}"
    return f"from {_number(lo)} to {_number(hi)}{unit}"


def tooltip(field: dict) -> str:
    """The setting's help, what it means in Blender, its range and unit, and what Auto does."""
    text = field["help"] + BLENDER_HELP.get(field["key"], "")
    if field["type"] in ("integer", "number") or (field["type"] == "array" and field.get("items") in ("integer",
                                                                                                       "number")):
        words = _range(field)
        if words and field["type"] == "array":
            text += f". Each value {words}"
        elif words:
            text += f". {words[0].upper()}{words[1:]}"
    elif field.get("unit"):
        text += f" ({field['unit']})"
    if field["key"] in AUTO_KEYS:
        text += f". Auto: {field.get('null_means') or 'chosen by the renderer'}"
    return text


def auto_toggle(key: str) -> str:
    """The panel's Auto checkbox of `key` (a property computed from the value: 0 = Auto)."""
    return f"{key}_auto"


@dataclass(frozen=True)
class Item:
    """One value on a panel: a Cubist property (`source` None) or a Blender property
    (`source` the data path from the scene, e.g. 'render')."""

    key: str
    source: Optional[str] = None
    label: Optional[str] = None


def group_items(group: str) -> list:
    """The values of a schema group, in the panel's order."""
    out = []
    for key, field in schema.SETTINGS.items():
        if field["group"] != group:
            continue
        if field["type"] == "array" and field.get("items") == "enum":
            out += [Item(toggle) for toggle in presets.PASS_TOGGLES]
        elif key in presets.BLENDER_KEYS:
            if key in BLENDER_PROPERTY:
                source, prop, label = BLENDER_PROPERTY[key]
                out.append(Item(prop, source, label))
        else:
            out.append(Item(key))
        out += [Item(k) for k, after in presets.ADDON_AFTER.items() if after == key]
        if key in BLENDER_AFTER:
            source, prop, label = BLENDER_AFTER[key]
            out.append(Item(prop, source, label))
    return out


def panel_items(panel: Panel) -> list:
    """(group, its values) of each group a panel shows."""
    return [(group, group_items(group)) for group in panel.groups]


def shown(key: str, c, scene) -> bool:
    return SHOWN.get(key, lambda c, scene: True)(c, scene)


def active(key: str, c, scene) -> bool:
    return ACTIVE.get(key, lambda c, scene: True)(c, scene)


def format_chosen(key: str, value: float) -> str:
    """What the renderer chose for an Auto setting, with its unit: '159.6°', '0.94'."""
    unit = schema.SETTINGS[key].get("unit")
    text = f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    if unit == "deg":
        return f"{value:.1f}\N{DEGREE SIGN}"
    return f"{text} {unit}" if unit else text
