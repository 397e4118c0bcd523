"""What a frame's render sends the renderer, besides the exported scene: the settings made from
the panel and the scene's facts, the shared facet layout's file and the plan for it (load it,
or compute and save it). The engine's F12 and Render Animation (engine.py) and the render
ahead of F12 (ahead.py) make their settings here, so a prepared job is F12's own.

No bpy here: the caller reads the panel, the scene's facts and the properties below on the
thread where it may (the main thread, or the render thread from its depsgraph).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from . import mapping, runner


# Settings that say where files go (the layout F12 saves, the mesh saliency cache), not what is
# painted: two jobs that differ only in them are the same picture from the same kept outputs.
FILE_KEYS = frozenset({"save_facets", "saliency_cache"})


@dataclass
class FrameInputs:
    """What the settings of one frame depend on, read from Blender beforehand."""

    panel: dict  # the Cubist panel's values (preferences.panel)
    facts: mapping.SceneFacts  # the exported scene's size, camera, world colour
    scene_name: str
    frame: int
    layout_frame: int
    static_facets: bool
    use_saliency_cache: bool
    folder: Path  # the layout and saliency cache folder (engine.layout_folder)
    binary: Path


@dataclass
class FrameSettings:
    settings: dict  # before the layout plan
    layout: Optional[Path]  # the shared layout file, when the frame uses one
    follow: bool  # facets follow the scene (Facet Motion: Follow)
    cache: Path  # the saliency cache folder

    @property
    def needs_source(self) -> bool:
        """Whether the layout's reuse depends on what the layout frame shows (its source)."""
        return self.layout is not None and (runner.follows_picture(self.settings) or self.follow)


def frame_settings(inputs: FrameInputs) -> FrameSettings:
    """The frame's settings (the panel's, the scene's facts, the saliency cache, what the binary
    knows) and its shared layout file."""
    panel = inputs.panel
    settings = mapping.settings_from_panel(panel, inputs.facts)
    # Facets that follow the scene carry every frame's facets from the layout frame's: its
    # layout and follow data are always shared (Static Facets or not).
    follow = runner.follows_scene(settings)
    layout = None
    if (inputs.static_facets or follow) and runner.uses_layout(settings):
        # The panel's seed, not the animated one: one layout for every frame.
        layout = runner.layout_path(inputs.folder, inputs.scene_name, {**settings, "seed": panel["seed"]},
                                    inputs.layout_frame)
    cache = Path(panel["saliency_cache"]) if panel["saliency_cache"] else inputs.folder / "saliency"
    # The renderer uses (and creates) the cache only when it computes mesh saliency.
    if inputs.use_saliency_cache:
        settings["saliency_cache"] = str(cache)
    # A binary set in the preferences may be older than the add-on.
    settings = runner.settings_for_binary(inputs.binary, settings)
    return FrameSettings(settings, layout, follow, cache)


@dataclass
class LayoutState:
    plan: runner.LayoutPlan
    broken: Optional[str]  # why the saved layout cannot be read, if it cannot
    current: Optional[bool]  # whether the saved layout can be reused (None: no layout)


def layout_state(fs: FrameSettings, source: Optional[str], frame: int, layout_frame: int) -> LayoutState:
    """What the frame does with the shared layout, from the files as they are now (read only:
    the caller forgets a stale source)."""
    layout = fs.layout
    broken = runner.layout_unreadable(layout) if layout is not None else None
    current = runner.layout_is_current(layout, source, fs.follow) and broken is None if layout is not None else None
    return LayoutState(runner.plan_layout(fs.settings, layout, frame, layout_frame, current), broken, current)


def renders_on_server(settings: dict) -> bool:
    """Whether the frame renders on the session's renderer: a frame whose facets follow a
    saved key frame is the binary's alone (its frames route)."""
    return not (settings.get("facet_motion") == "follow" and ("facets" in settings or "save_facets" in settings))


__all__ = ["FILE_KEYS", "FrameInputs", "FrameSettings", "LayoutState", "frame_settings", "layout_state",
           "renders_on_server"]
