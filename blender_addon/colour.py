"""Colour management for the painting (docs/blender.md, "Colours").

The renderer's picture is a finished painting: display-referred sRGB colours from a palette,
borders, colour transfer. Blender shows and saves a render through the scene's view transform,
and its default (AgX since Blender 4.0, Filmic before) tone-maps the painting a second time:
colours wash out. Blender's *Standard* view transform with no look, exposure 0, gamma 1 and no
curves shows the painting's own colours (the render result holds the PNG decoded to linear, and
Standard encodes it back exactly).

The policy, never a silent change to settings a user chose:
- A scene whose colour management is still the factory default (never configured) is set to
  Standard once, when its engine becomes Cubist; the Cubist panel says so and offers the
  previous view transform back in one click.
- Any other scene is left as set; whenever its view transform, look, exposure, gamma, curves
  or white balance would alter the painting, the panel shows a warning and a one-click fix.

Where that runs: never in `render()` (the render thread in the interface). On the main thread:
a message-bus subscription to the render engine setting (the interface), a load_post handler
(files saved before), and a render_init handler only when it runs on the main thread (`blender
-b` and bpy as a module, where render() is on the main thread too and the message bus is
not processed).
"""

import threading

import bpy
from bpy.props import BoolProperty, StringProperty

ENGINE_ID = "CUBIST"
# Subscriptions are dropped when a file loads: re-made in load_post.
_MSGBUS_OWNER = object()


def factory_view_transform() -> str:
    return "AgX" if bpy.app.version >= (4, 0, 0) else "Filmic"


class CubistColourState(bpy.types.PropertyGroup):
    checked: BoolProperty(
        name="Checked", description="The add-on has looked at this scene's colour management with Cubist selected",
        default=False)
    switched_from: StringProperty(
        name="Switched From", description="The view transform the add-on replaced with Standard (empty: none)",
        default="")


def never_configured(scene) -> bool:
    """Whether the scene's colour management is Blender's factory default, untouched."""
    v, d = scene.view_settings, scene.display_settings
    return (v.view_transform == factory_view_transform() and v.look == "None" and abs(v.exposure) < 1e-6
            and abs(v.gamma - 1.0) < 1e-6 and not v.use_curve_mapping
            and not getattr(v, "use_white_balance", False) and d.display_device == "sRGB")


def alterations(scene) -> list:
    """What in the scene's view settings would change the painting's colours (empty: none)."""
    v = scene.view_settings
    out = []
    if v.view_transform != "Standard":
        out.append(f"the view transform {v.view_transform}")
    if v.look not in {"None", ""}:
        out.append(f"the look {v.look}")
    if abs(v.exposure) > 1e-6:
        out.append(f"exposure {v.exposure:+.2f}")
    if abs(v.gamma - 1.0) > 1e-6:
        out.append(f"gamma {v.gamma:.2f}")
    if v.use_curve_mapping:
        out.append("curves")
    if getattr(v, "use_white_balance", False):
        out.append("white balance")
    return out


def show_painting_colours(scene) -> None:
    v = scene.view_settings
    v.view_transform = "Standard"
    v.look = "None"
    v.exposure = 0.0
    v.gamma = 1.0
    v.use_curve_mapping = False
    if hasattr(v, "use_white_balance"):
        v.use_white_balance = False


def apply_policy(scene) -> bool:
    """Once per scene with Cubist selected: a never-configured scene is set to Standard (and
    remembers what it was). Main thread only. True when the scene was changed."""
    if scene is None or scene.render.engine != ENGINE_ID:
        return False
    state = getattr(scene, "cubist_colour", None)
    if state is None or state.checked:
        return False
    state.checked = True
    if not never_configured(scene):
        return False
    previous = scene.view_settings.view_transform
    show_painting_colours(scene)
    state.switched_from = previous
    print(f"Cubist: scene '{scene.name}': view transform {previous} -> Standard, so renders show the "
          "painting's colours (Render Properties > Cubist to change it back)")
    return True


def _all_scenes() -> None:
    try:
        scenes = list(bpy.data.scenes)
    except AttributeError:  # bpy.data is restricted while add-ons register at startup
        return
    for scene in scenes:
        apply_policy(scene)


def _engine_changed(*_args) -> None:
    _all_scenes()


def _subscribe() -> None:
    bpy.msgbus.clear_by_owner(_MSGBUS_OWNER)
    bpy.msgbus.subscribe_rna(key=(bpy.types.RenderSettings, "engine"), owner=_MSGBUS_OWNER, args=(),
                             notify=_engine_changed)


@bpy.app.handlers.persistent
def _load_post(*_args) -> None:
    _subscribe()
    _all_scenes()


@bpy.app.handlers.persistent
def _render_init(scene=None, *_args) -> None:
    # In the interface this runs on the render-job thread: the scene is not ours to change
    # there (the message bus handled the engine switch on the main thread already).
    if threading.current_thread() is threading.main_thread():
        apply_policy(scene if isinstance(scene, bpy.types.Scene) else None)


def _first_check():
    _all_scenes()
    return None  # once


# ---------------------------------------------------------------------------------------------
# Panel and operators


class CUBIST_OT_painting_colours(bpy.types.Operator):
    """Set the scene's colour management to Standard, no look, exposure 0, gamma 1, no curves:
    renders show the painting's own colours"""

    bl_idname = "cubist.painting_colours"
    bl_label = "Show the Painting's Colours"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        scene = context.scene
        show_painting_colours(scene)
        scene.cubist_colour.checked = True
        return {"FINISHED"}


class CUBIST_OT_restore_view_transform(bpy.types.Operator):
    """Go back to the view transform the scene had before the add-on set Standard"""

    bl_idname = "cubist.restore_view_transform"
    bl_label = "Restore View Transform"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        state = context.scene.cubist_colour
        if state.switched_from:
            try:
                context.scene.view_settings.view_transform = state.switched_from
            except TypeError as e:  # a view transform this Blender lacks
                self.report({"ERROR"}, str(e))
                return {"CANCELLED"}
            state.switched_from = ""
        return {"FINISHED"}


def draw_notice(layout, scene, context=None) -> None:
    """The colour notice or warning at the top of the Cubist panel, wrapped to the panel's
    width (one label would be cut off with an ellipsis in the default Properties editor)."""
    from .preferences import draw_wrapped

    state = getattr(scene, "cubist_colour", None)
    altered = alterations(scene)
    if altered:
        box = layout.box()
        what = ", ".join(altered)
        verb = "changes" if len(altered) == 1 else "change"
        draw_wrapped(box, f"{what[0].upper()}{what[1:]} {verb} the painting's colours", "ERROR", context)
        box.operator(CUBIST_OT_painting_colours.bl_idname, icon="COLOR")
    elif state is not None and state.switched_from:
        box = layout.box()
        draw_wrapped(box, f"View transform set to Standard (was {state.switched_from}): renders show the "
                          "painting's colours", "INFO", context)
        box.operator(CUBIST_OT_restore_view_transform.bl_idname, text=f"Use {state.switched_from}")


classes = (CubistColourState, CUBIST_OT_painting_colours, CUBIST_OT_restore_view_transform)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.cubist_colour = bpy.props.PointerProperty(type=CubistColourState)
    bpy.app.handlers.load_post.append(_load_post)
    bpy.app.handlers.render_init.append(_render_init)
    _subscribe()
    if not bpy.app.background:
        bpy.app.timers.register(_first_check, first_interval=0.1)


def unregister():
    bpy.msgbus.clear_by_owner(_MSGBUS_OWNER)
    for handlers, fn in ((bpy.app.handlers.load_post, _load_post), (bpy.app.handlers.render_init, _render_init)):
        if fn in handlers:
            handlers.remove(fn)
    if bpy.app.timers.is_registered(_first_check):
        bpy.app.timers.unregister(_first_check)
    del bpy.types.Scene.cubist_colour
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
