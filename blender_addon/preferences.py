"""Add-on preferences: a `cubist` binary of the user's own (used first when set), and what the
add-on will run, or why it has nothing to run (e.g. a zip without a renderer for this platform).
Also what the F12 engine (`engine.py`) and the viewport (`viewport/`) both read without
`bpy.context` (the render thread has no window): the preferences and the Cubist panel's values,
so neither imports the other for them."""

import textwrap

import bpy

from . import runner
from .properties import panel_values


def _package():
    # `cubist` as a legacy add-on, `bl_ext.<repo>.cubist` as an extension.
    return __package__


def draw_wrapped(layout, text: str, icon: str = "NONE", context=None) -> None:
    """A long message as several labels, so a panel as narrow as the Properties editor shows
    all of it (one label is cut off with an ellipsis)."""
    width = 60
    region = getattr(context, "region", None) if context is not None else None
    if region is not None and getattr(region, "width", 0) > 0:
        scale = getattr(getattr(context, "preferences", None), "system", None)
        px = 7.0 * (getattr(scale, "ui_scale", 1.0) or 1.0)
        width = max(24, int((region.width - 40) / px))
    col = layout.column(align=True)
    for i, line in enumerate(textwrap.wrap(text, width) or [""]):
        col.label(text=line, icon=icon if i == 0 else "BLANK1")


def _render_ahead_changed(prefs, context) -> None:
    from . import ahead  # which reads these preferences

    ahead.preference_changed(prefs, context)


class CubistPreferences(bpy.types.AddonPreferences):
    bl_idname = _package()

    binary_path: bpy.props.StringProperty(
        name="Cubist Binary",
        description="A cubist renderer you built (`cargo build --release`), or its folder: used first when set, "
                    "and checked with `cubist --version`. Empty: the renderer bundled with the add-on, else "
                    "cubist on PATH, else the project's target/release",
        subtype="FILE_PATH",
        default="",
    )

    render_ahead: bpy.props.BoolProperty(
        name="Render Ahead",
        description="While the scene is still (a second without edits), render the F12 picture in the "
                    "background on the session's renderer, so that F12 shows it at once. Uses the CPU while "
                    "you do not edit; any edit stops it. Only for scenes whose render engine is Cubist, and "
                    "not while a 3D view renders in Rendered shading",
        default=True,
        update=lambda self, context: _render_ahead_changed(self, context),
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "binary_path")
        layout.prop(self, "render_ahead")
        pref = bpy.path.abspath(self.binary_path) if self.binary_path else ""
        try:
            source, found = runner.locate_binary(pref)
            version = runner.binary_version(found)
            layout.label(text=f"Using {found} ({version}, {source})", icon="CHECKMARK")
        except runner.CubistError as e:
            draw_wrapped(layout, str(e), "ERROR", context)
            return
        missing = runner.missing_platform_binary()
        if missing and not pref:
            draw_wrapped(layout, f"Note: {missing}.", "INFO", context)


# Blender's preferences (a pointer to its global preferences, valid for the whole session),
# taken on the main thread when the add-on registers: the render thread must not read
# `bpy.context`.
_preferences = None


def remember(preferences) -> None:
    """Keeps Blender's preferences, taken on the main thread when the add-on registers."""
    global _preferences
    _preferences = preferences


def addon_preferences(context=None):
    prefs = context.preferences if context is not None else _preferences
    if prefs is None:
        return None
    for name in (__package__, __package__.rsplit(".", 1)[-1]):
        addon = prefs.addons.get(name)
        if addon is not None:
            return addon.preferences
    return None


def panel(props) -> dict:
    """The Cubist panel's values, with its file paths made absolute."""
    values = panel_values(props)
    for key in ("facet_map", "palette_image", "layout_file", "saliency_cache"):
        if values[key]:
            values[key] = bpy.path.abspath(values[key])
    return values


classes = (CubistPreferences,)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
