"""Panel defaults and presets, taken from the renderer itself (no bpy).

`renderer_presets.json` is what `cubist settings --preset NAME` prints for every preset of
the bundled binary, and `renderer_schema.json` what `cubist settings --schema` prints (both
written by `scripts/sync_addon_presets.py`; a test and the extension build refuse copies that
differ from the binary's). The panel's defaults are the `analytic` preset's values, so an
untouched panel sends exactly the settings `cubist render` uses, and applying a preset in
Blender gives exactly `cubist render --preset NAME`; the keys, their types, the presets'
names and descriptions come from the schema: nothing here copies the renderer by hand.

`panel_from_settings` is the inverse of `mapping.settings_from_panel`: settings JSON -> the
panel's values. Values the settings leave to the scene (null) are the panel's "automatic" 0.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Mapping

from . import runner, schema

PRESETS_FILE = Path(__file__).resolve().parent / "renderer_presets.json"

# Settings enum values <-> panel enum identifiers (Blender identifiers: upper case, `_`).


def enum_id(value: str) -> str:
    return value.upper().replace("-", "_")


def enum_value(ident: str) -> str:
    return ident.lower().replace("_", "-")


def load_renderer_presets(path: Path = PRESETS_FILE) -> dict:
    """{preset name: the settings `cubist settings --preset NAME` prints}."""
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    if not isinstance(data, dict) or "analytic" not in data:
        raise runner.CubistError(f"{path.name}: not a table of the renderer's presets")
    return data


RENDERER_PRESETS = load_renderer_presets()

# Preset name -> (menu label, description), the renderer's presets in its order (menu order).
PRESET_LABELS = {name: (schema.label(name), help) for name, help in schema.PRESETS.items()}

# Settings keys Blender decides, not the panel: the render size, Film > Transparent, the
# active camera and its focus, the per-frame layout files (and the follow data saved beside
# them), the saliency cache folder (beside the layout), external files (the exported GLB is
# self-contained) and the frame range (Blender's own: the add-on renders one frame per
# process, so `frames` is never sent). How facets move between frames (`facet_motion`) is the
# panel's.
BLENDER_KEYS = frozenset({"width", "height", "transparent", "camera_position", "camera_target", "camera_up",
                          "focus_distance", "facets", "save_facets", "saliency_cache", "allow_external_files",
                          "frames"})

# The panel's enum settings (those Blender decides are not on the panel).
ENUM_KEYS = tuple(k for k in schema.ENUM_KEYS if k not in BLENDER_KEYS)

# Panel properties with no settings key of their own: how Blender's scene maps to settings,
# animation, and files. The renderer has no say in these.
ADDON_DEFAULTS = {
    "animate_seed": False,
    "use_camera_lens": True,
    "use_camera_focus": True,
    "use_world_background": True,
    "static_facets": True,
    "layout_frame": 1,
    "layout_folder": "",
    "layout_file": "",
    "use_saliency_cache": True,
    "saliency_cache": "",
}

# Render passes: panel toggle -> the renderer's pass name (`pass_facet_ids` for `facet-ids`).
# The 16-bit RGBA motion pass is written for animation frames of the command line only (a
# render of one frame has no next frame): not a toggle of the panel.
PASS_TOGGLES = {"pass_" + name.replace("-", "_"): name for name, _help in schema.choices("passes")
                if schema.pass_format(name) != "rgba16"}

# Panel properties with no settings key of their own, placed after the settings key whose
# panel they belong to (the order of the panel's values, of the panels (panel_layout.py), and
# of saved preset files).
ADDON_AFTER = {
    "animate_seed": "seed",
    "use_camera_lens": "ambiguity",
    "use_camera_focus": "framing",
    "use_world_background": "shadows",
    "layout_file": "plane_outlines",
    "static_facets": "facet_motion",
    "layout_frame": "facet_motion",
    "layout_folder": "facet_motion",
    "use_saliency_cache": "saliency_method",
    "saliency_cache": "saliency_method",
}


def format_number_list(values) -> str:
    """[5, 30, 120] -> '5, 30, 120'; floats keep every digit ('0.05'), whole ones lose '.0'."""
    out = []
    for v in values:
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        out.append(repr(v))
    return ", ".join(out)


def panel_from_settings(settings: Mapping[str, object]) -> dict:
    """The panel's values for a settings object (every key of `cubist settings`), by each
    key's type in the schema. Raises CubistError on a key the add-on does not know, so a new
    renderer setting cannot be silently missing from the panel."""
    s = dict(settings)
    unknown = sorted(set(s) - schema.SETTINGS_KEYS)
    if unknown:
        raise runner.CubistError(f"settings the add-on does not know: {', '.join(unknown)}")
    missing = sorted(schema.SETTINGS_KEYS - set(s))
    if missing:
        raise runner.CubistError(f"settings missing: {', '.join(missing)}")
    p: dict = {}
    for key, field in schema.SETTINGS.items():
        if key in BLENDER_KEYS:
            continue
        v, kind, items = s[key], field["type"], field.get("items")
        if kind == "enum":
            p[key] = enum_id(str(v))
        elif kind == "boolean":
            p[key] = bool(v)
        elif kind == "integer":
            p[key] = int(v)
        elif kind == "number" and v is None:
            # null = chosen by the renderer: its value where the schema states one (the
            # convergence angle), else the panel's "automatic" 0 (out of the settings' range).
            auto = schema.automatic(key, str(s.get("camera")))
            p[key] = float(auto) if auto is not None else 0.0
        elif kind == "number":
            p[key] = float(v)
        elif kind == "path":
            p[key] = str(v or "")
        elif kind == "array" and items == "enum":
            for toggle, name in PASS_TOGGLES.items():
                p[toggle] = name in list(v)
        elif kind == "array" and field.get("length"):
            p[key] = tuple(float(c) for c in v)
        elif kind == "array":
            p[key] = format_number_list([int(x) if items == "integer" else float(x) for x in v])
        else:
            raise runner.CubistError(f"setting {key}: type {kind} is not one the add-on reads")
    return p


def _ordered_defaults() -> dict:
    """Every panel property's default, in the renderer's order of its settings keys, each
    add-on property after the key it belongs with (the preset files' order too)."""
    base = panel_from_settings(RENDERER_PRESETS["analytic"])
    values = {**base, **ADDON_DEFAULTS}
    assert set(ADDON_AFTER) == set(ADDON_DEFAULTS), sorted(set(ADDON_AFTER) ^ set(ADDON_DEFAULTS))
    order = []
    for key in base:
        order.append(key)
        order.extend(k for k, after in ADDON_AFTER.items() if after == key)
    assert set(order) == set(values), sorted(set(order) ^ set(values))
    return {k: values[k] for k in order}


DEFAULTS = _ordered_defaults()

# Panel values a preset does not touch: sampling and seed (quality, not look), the scene's own
# choices (camera lens and focus, whether the world's colour is the ground), files, animation
# (facet motion included), passes, the saliency method (accuracy, not look). The ground colour
# is a look's: the analytic preset's is dark, the others' lighter.
NOT_IN_PRESETS = frozenset({"spp", "seed", "animate_seed", "use_camera_lens", "use_camera_focus",
                            "use_world_background", "facet_map", "static_facets", "facet_motion",
                            "layout_folder", "layout_frame", "layout_file", "saliency_method",
                            "use_saliency_cache", "saliency_cache"} | set(PASS_TOGGLES))
LOOK_KEYS = tuple(k for k in DEFAULTS if k not in NOT_IN_PRESETS)

# Variations on a renderer preset: the thesis's other methods. (base preset, panel values.)
VARIANTS = {
    "Voronoi Facets": ("analytic", {"faceting": "VORONOI", "facet_count": schema.default("facet_count"),
                                    "grid_cells": schema.default("grid_cells")}),
    "Patch Facets": ("analytic", {"faceting": "PATCH", "patch_count": schema.default("patch_count"),
                                  "occlusion": float(schema.default("occlusion"))}),
    "Random Imprecision (study baseline)": ("analytic", {"imprecision": "RANDOM"}),
    "Linear Facets": ("analytic", {"facet_projection": "LINEAR", "facet_fov": 0.0}),
}

# Built-in menu entries: label -> (renderer preset, panel overrides). Order = menu order.
BUILTIN = {label: (name, {}) for name, (label, _) in PRESET_LABELS.items()}
BUILTIN.update(VARIANTS)


def renderer_preset_values(name: str) -> dict:
    """The panel values (LOOK_KEYS) of the renderer's preset `name` ('braque')."""
    if name not in RENDERER_PRESETS:
        raise KeyError(f"unknown renderer preset {name!r}")
    values = panel_from_settings(RENDERER_PRESETS[name])
    return {k: values[k] for k in LOOK_KEYS}


def preset_values(label: str) -> dict:
    """The panel values a built-in menu entry sets (every look value, so nothing of the
    previous look is left)."""
    if label not in BUILTIN:
        raise KeyError(f"unknown preset {label!r}")
    name, overrides = BUILTIN[label]
    values = renderer_preset_values(name)
    values.update(overrides)
    return values
