"""Facet layouts across frames (SPEC "Animation"): one layout file per set of layout-deciding
settings, computed on the layout frame, reused by every frame, process and farm machine; a
Segment or planes layout is computed again when what the layout frame shows changes.

Facets that follow the scene (`facet_motion` follow) also need the layout frame's follow data,
which the renderer saves beside the layout (`<layout>.follow`: the key frame's camera, its
triangles and what each pixel showed). Every frame, rendered in its own process from its own
exported scene, carries its facets from that key frame, so any frame rendered alone (F12, a
farm chunk) is the same frame a whole Render Animation renders. The follow data is per image
size and is made from the layout frame's exported scene, so a follow layout's file name also
holds the size, and its source (the layout frame's scene) is always checked."""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Optional

# Settings that decide a facet layout (besides the pre-render, for the faceting methods that
# follow the picture): a change of any of them gives a new layout file name, so a stale
# layout is never reused.
LAYOUT_KEYS = ("faceting", "facet_map", "facet_count", "grid_cells", "patch_count", "occlusion", "segments",
               "thresholds", "superpixels", "weight_colour", "weight_normal", "weight_depth", "weight_object",
               "weight_saliency", "planes", "plane_detail", "plane_outlines", "saliency_method", "part_saliency",
               "seed")

# Faceting methods whose layout follows the pre-render (its saliency, outlines, segments): a
# saved layout of theirs is computed again when what the layout frame shows changes.
PICTURE_FACETINGS = ("segment", "planes")


def follows_picture(settings: Mapping[str, object]) -> bool:
    """Whether the layout of these settings depends on the pre-render (`PICTURE_FACETINGS`)."""
    return settings.get("faceting") in PICTURE_FACETINGS

# Settings that decide the pre-render a Segment layout is computed from (besides the layout
# frame's scene itself). Not the size: the layout is resolution-independent (its aspect ratio
# is in the file name), so a 50% preview and the final share it.
PRERENDER_KEYS = ("camera", "ambiguity", "framing", "focus_distance", "camera_position", "camera_target",
                  "camera_up", "camera_size", "fill", "shadows", "background", "exposure", "spp")


def follows_scene(settings: Mapping[str, object]) -> bool:
    """Whether facets follow the scene (`facet_motion` follow): the layout comes with the
    layout frame's follow data (`follow_path`), which every frame carries its facets from."""
    return settings.get("facet_motion") == "follow" and settings.get("faceting", "none") != "none"


def follow_path(layout: Path) -> Path:
    """The follow data the renderer saves beside a layout (`<layout file name>.follow`)."""
    return layout.with_name(layout.name + ".follow")


def layout_key(settings: Mapping[str, object], layout_frame: int = 1) -> str:
    """A short hash of the settings that decide a layout, of the frame it is computed on,
    and of the image's aspect ratio (the layout is resolution-independent, so a 50% preview
    and the final share it). Facets that follow: also the image size (the follow data holds
    a triangle and a depth per pixel), so a preview and the final keep their own."""
    w, h = settings.get("width", 800), settings.get("height", 600)
    data = {k: settings.get(k) for k in LAYOUT_KEYS}
    data["layout_frame"] = int(layout_frame)
    data["aspect"] = round(float(w) / float(h), 4)
    if follows_scene(settings):
        # Only then: the names of static layouts saved before stay the same.
        data["follow"] = [int(w), int(h)]
    text = json.dumps(data, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:10]


def layout_path(folder: Path, scene_name: str, settings: Mapping[str, object], layout_frame: int = 1) -> Path:
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in scene_name) or "scene"
    return folder / f"{safe}.{layout_key(settings, layout_frame)}.facets.json"


def uses_layout(settings: Mapping[str, object]) -> bool:
    """Whether the add-on manages a layout file for these settings: faceted, and no layout
    file of the user's (`facets`) already given."""
    return settings.get("faceting", "none") != "none" and not settings.get("facets")


@dataclass
class LayoutPlan:
    """What a frame's render does with the shared layout file: `settings` renders the frame
    (with `facets` = load the layout, or `save_facets` = compute and save it). When
    `prepass_frame` is set, the layout is first computed on that frame with
    `layout_prepass(...)`: a chunk of an animation that does not start on the layout frame
    must still get the layout frame's layout, or two farm machines would compute different ones."""

    settings: dict
    prepass_frame: Optional[int] = None


def plan_layout(settings: Mapping[str, object], layout: Optional[Path], frame: int, layout_frame: int,
                current: Optional[bool] = None) -> LayoutPlan:
    """`current`: whether the saved layout is still the layout frame's (`layout_is_current`);
    None: whenever the file exists."""
    s = dict(settings)
    if layout is None or not uses_layout(s):
        return LayoutPlan(s)
    if current is None:
        current = layout.is_file()
    if current:
        s["facets"] = str(layout)
        return LayoutPlan(s)
    if frame == layout_frame:
        s["save_facets"] = str(layout)
        return LayoutPlan(s)
    s["facets"] = str(layout)
    return LayoutPlan(s, prepass_frame=layout_frame)


def layout_source(scene_file: Path, settings: Mapping[str, object]) -> str:
    """What a Segment layout was computed from: a hash of the layout frame's exported scene
    and of the settings that shape its pre-render. A layout whose recorded source differs is
    stale (the camera, an object, a light or a material moved or changed on the layout frame)."""
    h = hashlib.sha256()
    with open(scene_file, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    view = {k: settings.get(k) for k in PRERENDER_KEYS}
    h.update(json.dumps(view, sort_keys=True, default=str).encode())
    return h.hexdigest()


def source_path(layout: Path) -> Path:
    return layout.with_name(layout.name + ".source")


def layout_is_current(layout: Path, source: Optional[str], follow: bool = False) -> bool:
    """Whether the saved layout can be reused: it exists (with `follow`, its follow data too)
    and, when its source matters (`source` given: Segment or planes faceting, facets that
    follow), was computed from that source."""
    if not layout.is_file() or (follow and not follow_path(layout).is_file()):
        return False
    if source is None:
        return True
    try:
        return source_path(layout).read_text(encoding="utf-8").strip() == source
    except OSError:
        return False


def layout_unreadable(layout: Path) -> Optional[str]:
    """Why a saved layout file cannot be the renderer's layout (truncated, overwritten, not
    JSON), in a few words; None when it reads as a layout or does not exist. Such a file is
    computed again and saved over, rather than failing every render until it is removed."""
    try:
        data = json.loads(layout.read_bytes().decode("utf-8"))
    except FileNotFoundError:
        return None
    except OSError as e:
        return e.strerror or str(e)
    except UnicodeDecodeError:
        return "not UTF-8 text"
    except ValueError as e:
        return f"not valid JSON: {e}"
    if not isinstance(data, dict):
        return "not a facet layout"
    return None


def forget_source(layout: Path) -> None:
    """Before the layout is computed again: until the new source is recorded, it is stale."""
    source_path(layout).unlink(missing_ok=True)


def record_source(layout: Path, source: str) -> None:
    """After the renderer saved the layout: what it was computed from (written atomically)."""
    p = source_path(layout)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp")
    tmp.write_text(source + "\n", encoding="utf-8")
    os.replace(tmp, p)


def layout_prepass(settings: Mapping[str, object], layout: Path) -> dict:
    """The settings of the render that only computes and saves the layout (on the layout
    frame, with that frame's camera): no passes, the image is discarded."""
    s = dict(settings)
    s.pop("facets", None)
    s["save_facets"] = str(layout)
    s["passes"] = []
    return s
