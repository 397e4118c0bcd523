"""Render-properties panels for the Cubist engine: the Cubist panel (the presets as a grid of
their pictures, the colour notice, errors) and one sub-panel per entry of panel_layout.PANELS
(Camera, Facets, Spatial Imprecision with Mesh Saliency, Painterly, Sampling, Passes, Output),
each drawn from the settings schema with no line of its own per setting; the preset menu and
the operators behind the buttons (apply/save presets, recompute the facet layout)."""

import bpy
from bl_operators.presets import AddPresetBase

from . import colour, engine, panel_layout, preferences, presets, properties, runner
from .properties import apply_look

PRESET_SUBDIR = "cubist"


class CUBIST_OT_apply_preset(bpy.types.Operator):
    """Set the Cubist panel to a built-in preset"""

    bl_idname = "cubist.apply_preset"
    bl_label = "Apply Cubist Preset"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Preset")

    @classmethod
    def description(cls, context, properties):
        return f"Set the Cubist settings to the '{properties.name}' preset"

    def execute(self, context):
        try:
            values = presets.preset_values(self.name)
        except KeyError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        apply_look(context.scene.cubist, values)
        return {"FINISHED"}


class CUBIST_OT_preset_add(AddPresetBase, bpy.types.Operator):
    """Save the Cubist settings as a preset, or remove the chosen one"""

    bl_idname = "cubist.preset_add"
    bl_label = "Add Cubist Preset"
    preset_menu = "CUBIST_MT_presets"
    preset_defines = ["cubist = bpy.context.scene.cubist"]
    # The preset first: setting it resets the look, the file's other values follow.
    preset_values = [f"cubist.{k}" for k in presets.LOOK_KEYS]
    preset_subdir = PRESET_SUBDIR


class CUBIST_MT_presets(bpy.types.Menu):
    bl_label = "Cubist Presets"
    preset_subdir = PRESET_SUBDIR
    preset_operator = "script.execute_preset"

    def draw(self, context):
        layout = self.layout
        for label, (_name, overrides) in presets.BUILTIN.items():
            if overrides and label == next(iter(presets.VARIANTS)):
                layout.separator()
            layout.operator(CUBIST_OT_apply_preset.bl_idname, text=label).name = label
        paths = bpy.utils.preset_paths(PRESET_SUBDIR)
        if paths:
            layout.separator()
            self.path_menu(paths, self.preset_operator, props_default={"menu_idname": self.bl_idname})


class CUBIST_OT_recompute_layout(bpy.types.Operator):
    """Delete the saved facet layout of the current settings: the next render computes it again
    on the Layout Frame"""

    bl_idname = "cubist.recompute_layout"
    bl_label = "Recompute Facet Layout"

    def execute(self, context):
        try:
            path = engine.current_layout_path(context.scene)
        except runner.CubistError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if path.is_file():
            path.unlink()
            # The follow data and the source belong to the layout.
            runner.follow_path(path).unlink(missing_ok=True)
            runner.source_path(path).unlink(missing_ok=True)
            self.report({"INFO"}, f"Removed {path.name}: the next render computes a new layout")
        else:
            self.report({"INFO"}, "No saved layout yet: the next render computes one")
        return {"FINISHED"}


class CubistPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {engine.ENGINE_ID}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class CUBIST_PT_render(CubistPanel, bpy.types.Panel):
    bl_label = "Cubist"

    def draw_header_preset(self, context):
        row = self.layout.row(align=True)
        row.menu(CUBIST_MT_presets.__name__, text="", icon="PRESET")
        row.operator(CUBIST_OT_preset_add.bl_idname, text="", icon="ADD")
        row.operator(CUBIST_OT_preset_add.bl_idname, text="", icon="REMOVE").remove_active = True

    def draw(self, context):
        layout = self.layout
        c = context.scene.cubist
        # What stops a render first, then the colour notice, then the presets.
        prefs = engine.addon_preferences(context)
        try:
            pref = bpy.path.abspath(prefs.binary_path) if prefs is not None and prefs.binary_path else ""
            runner.find_binary(pref)
        except runner.CubistError as e:
            preferences.draw_wrapped(layout, str(e), "ERROR", context)
        err = engine.last_run.get("error")
        if err:
            preferences.draw_wrapped(layout, f"Last render: {err}", "ERROR", context)
        colour.draw_notice(layout, context.scene, context)
        # The presets as a grid of their pictures, as Blender shows material previews.
        for group in panel_layout.ROOT_GROUPS:
            for item in panel_layout.group_items(group):
                col = layout.column()
                col.template_icon_view(c, item.key, show_labels=True, scale=5.0, scale_popup=6.0)
                col.label(text=_enum_label(c, item.key))


def _enum_label(data, key: str) -> str:
    prop = data.bl_rna.properties[key]
    value = getattr(data, key)
    return next((i.name for i in prop.enum_items if i.identifier == value), value)


def draw_item(layout, item, c, scene) -> None:
    """One value of a panel: a Cubist property (an Auto checkbox beside a setting the renderer
    may choose) or the Blender property a setting comes from."""
    if item.source is not None:
        layout.prop(getattr(scene, item.source), item.key, text=item.label)
        return
    if item.key not in panel_layout.AUTO_KEYS:
        row = layout.row()
        row.active = panel_layout.active(item.key, c, scene)
        row.prop(c, item.key)
        return
    # "Auto" (with what the last render chose, when the renderer reported it), else the value
    # after an unticked box.
    row = layout.row(heading=c.bl_rna.properties[item.key].name, align=True)
    row.active = panel_layout.active(item.key, c, scene)
    toggle = panel_layout.auto_toggle(item.key)
    if getattr(c, item.key) == 0.0:
        chosen = properties.chosen_values().get(item.key)
        row.prop(c, toggle, text=f"Auto, {panel_layout.format_chosen(item.key, chosen)}" if chosen else "Auto")
    else:
        row.prop(c, toggle, text="")
        row.prop(c, item.key, text="")


def draw_group(layout, group: str, items: list, c, scene, context) -> None:
    """A schema group's values (panel_layout: which are shown, greyed, under a heading)."""
    col = layout.column()
    col.active = panel_layout.GROUP_ACTIVE.get(group, lambda c, scene: True)(c, scene)
    block, left = col, 0
    for item in items:
        if item.source is None and not panel_layout.shown(item.key, c, scene):
            left = max(left - 1, 0)
            continue
        if item.key in panel_layout.HEADINGS:
            heading, left = panel_layout.HEADINGS[item.key]
            block = col.column(heading=heading, align=True)
        target = block if left > 0 else col
        left = max(left - 1, 0)
        draw_item(target, item, c, scene)
        extra = AFTER_ITEM.get(item.key)
        if extra is not None:
            extra(col, c, scene, context)


def draw_layout_state(layout, c, scene, context) -> None:
    """The saved facet layout's state and the button that computes it again."""
    sub = layout.column()
    sub.active = panel_layout.active("layout_folder", c, scene)
    try:
        path = engine.current_layout_path(scene)
        follow = c.facet_motion == "FOLLOW"
        if not path.is_file() or (follow and not runner.follow_path(path).is_file()):
            state = f"computed on frame {c.layout_frame} at next render"
        elif c.faceting in ("SEGMENT", "PLANES") or follow:
            state = f"saved (again when frame {c.layout_frame}'s view changes)"
        else:
            state = "saved"
        sub.label(text=f"{path.name}: {state}", icon="FILE")
    except runner.CubistError as e:
        sub.label(text=str(e), icon="ERROR")
    sub.operator(CUBIST_OT_recompute_layout.bl_idname, icon="FILE_REFRESH")


# What a panel draws after a value besides the value itself (a state, a button).
AFTER_ITEM = {"layout_folder": draw_layout_state}


def group_panel(spec: panel_layout.Panel) -> type:
    """The sub-panel of `spec`: its groups' values, drawn from the schema (panel_layout)."""
    groups = panel_layout.panel_items(spec)

    def draw(self, context):
        scene = context.scene
        c = scene.cubist
        layout = self.layout
        layout.use_property_split = True
        for i, (group, items) in enumerate(groups):
            if i:
                # A further group of the panel under its own name (Facets > Animation).
                layout.separator()
                layout.label(text=group)
            draw_group(layout, group, items, c, scene, context)

    namespace = {"bl_label": spec.label, "draw": draw, "__doc__": f"Cubist {spec.label} settings"}
    if spec.parent is not None:
        namespace["bl_parent_id"] = f"CUBIST_PT_{spec.parent}"
    if spec.closed:
        namespace["bl_options"] = {"DEFAULT_CLOSED"}
    return type(f"CUBIST_PT_{spec.ident}", (CubistPanel, bpy.types.Panel), namespace)


# One sub-panel per entry of panel_layout.PANELS (a child after its parent), the Cubist panel
# their parent.
SUBPANELS = tuple(group_panel(spec) for spec in panel_layout.PANELS)
for _panel in SUBPANELS:
    _panel.bl_parent_id = getattr(_panel, "bl_parent_id", "CUBIST_PT_render")
    globals()[_panel.__name__] = _panel  # ui.CUBIST_PT_camera...


classes = (
    CUBIST_OT_apply_preset,
    CUBIST_OT_preset_add,
    CUBIST_MT_presets,
    CUBIST_OT_recompute_layout,
    CUBIST_PT_render,
    *SUBPANELS,
)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
