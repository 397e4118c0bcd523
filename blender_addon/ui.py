"""Render-properties panels for the Cubist engine, grouped as the thesis groups its parameters
(Camera, Facets, Spatial imprecision with Mesh saliency, Painterly, Sampling, Passes, Output),
the preset menu, and the operators behind its buttons (apply/save presets, recompute the facet
layout)."""

import bpy
from bl_operators.presets import AddPresetBase

from . import colour, engine, preferences, presets, runner
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
        row.menu(CUBIST_MT_presets.__name__, text=CUBIST_MT_presets.bl_label)
        row.operator(CUBIST_OT_preset_add.bl_idname, text="", icon="ADD")
        row.operator(CUBIST_OT_preset_add.bl_idname, text="", icon="REMOVE").remove_active = True

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(context.scene.cubist, "preset")
        colour.draw_notice(layout, context.scene)
        prefs = engine.addon_preferences(context)
        try:
            pref = bpy.path.abspath(prefs.binary_path) if prefs is not None and prefs.binary_path else ""
            runner.find_binary(pref)
        except runner.CubistError as e:
            preferences.draw_wrapped(layout, str(e), "ERROR", context)
        err = engine.last_run.get("error")
        if err:
            layout.label(text=f"Last render: {err}", icon="ERROR")


class CUBIST_PT_camera(CubistPanel, bpy.types.Panel):
    bl_label = "Camera"
    bl_parent_id = "CUBIST_PT_render"

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        layout.prop(c, "camera")
        if c.camera in {"PERSPECTIVE", "ORTHOGRAPHIC"}:
            layout.prop(c, "use_camera_lens")
        if c.camera != "ORTHOGRAPHIC" and not (c.camera == "PERSPECTIVE" and c.use_camera_lens):
            layout.prop(c, "ambiguity")
        layout.prop(c, "use_camera_focus")
        layout.prop(c, "framing")
        row = layout.row()
        row.active = c.framing == "FIT"
        row.prop(c, "fill")
        if c.camera in {"PLANAR", "CYLINDRICAL", "ORTHOGRAPHIC"}:
            layout.prop(c, "camera_size")


class CUBIST_PT_facets(CubistPanel, bpy.types.Panel):
    bl_label = "Facets"
    bl_parent_id = "CUBIST_PT_render"

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        layout.prop(c, "faceting")
        f = c.faceting
        if f == "CONSTANT":
            layout.prop(c, "facet_map")
        elif f == "VORONOI":
            layout.prop(c, "facet_count")
            layout.prop(c, "grid_cells")
        elif f == "PATCH":
            layout.prop(c, "patch_count")
            layout.prop(c, "occlusion")
        elif f == "PLANES":
            layout.prop(c, "planes")
            layout.prop(c, "plane_detail")
            layout.prop(c, "plane_outlines")
        elif f == "SEGMENT":
            layout.prop(c, "segments")
            layout.prop(c, "thresholds")
            layout.prop(c, "superpixels")
            col = layout.column(heading="Affinity", align=True)
            for key in ("weight_colour", "weight_normal", "weight_depth", "weight_object", "weight_saliency"):
                col.prop(c, key)
        layout.prop(c, "layout_file")
        if f == "NONE":
            return
        follow = c.facet_motion == "FOLLOW"
        col = layout.column(heading="Animation")
        col.prop(c, "facet_motion")
        if c.layout_file:
            return
        row = col.row()
        row.active = not follow  # facets that follow always share the layout frame's
        row.prop(c, "static_facets")
        sub = layout.column()
        sub.active = c.static_facets or follow
        sub.prop(c, "layout_frame")
        sub.prop(c, "layout_folder")
        try:
            path = engine.current_layout_path(context.scene)
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


class CUBIST_PT_imprecision(CubistPanel, bpy.types.Panel):
    bl_label = "Spatial Imprecision"
    bl_parent_id = "CUBIST_PT_render"

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        layout.active = c.faceting != "NONE"
        layout.prop(c, "imprecision")
        layout.prop(c, "discontinuity")
        layout.prop(c, "aim_min_coverage")
        layout.prop(c, "aim_width_share")
        layout.prop(c, "neighborhood")
        layout.prop(c, "facet_projection")
        if c.facet_projection == "LINEAR":
            layout.prop(c, "facet_fov")


class CUBIST_PT_saliency(CubistPanel, bpy.types.Panel):
    bl_label = "Mesh Saliency"
    bl_parent_id = "CUBIST_PT_imprecision"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        layout.prop(c, "saliency_method")
        layout.prop(c, "use_saliency_cache")
        row = layout.row()
        row.active = c.use_saliency_cache
        row.prop(c, "saliency_cache")


class CUBIST_PT_painterly(CubistPanel, bpy.types.Panel):
    bl_label = "Painterly"
    bl_parent_id = "CUBIST_PT_render"

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        col = layout.column(align=True)
        col.prop(c, "border_style")
        col.prop(c, "border_width")
        col.prop(c, "border_strength")
        col = layout.column(align=True)
        col.prop(c, "silhouette_width")
        col.prop(c, "silhouette_strength")
        layout.prop(c, "palette")
        layout.prop(c, "palette_image")
        layout.prop(c, "colors")
        layout.prop(c, "gradients")
        layout.prop(c, "plane_light")
        layout.prop(c, "chiaroscuro")
        col = layout.column(align=True)
        col.prop(c, "brushwork")
        col.prop(c, "stroke_length")
        col.prop(c, "stroke_width")
        layout.prop(c, "canvas_grain")


class CUBIST_PT_sampling(CubistPanel, bpy.types.Panel):
    bl_label = "Sampling"
    bl_parent_id = "CUBIST_PT_render"

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        layout.prop(c, "spp")
        layout.prop(c, "aa_threshold")
        layout.prop(c, "seed")
        layout.prop(c, "animate_seed")


class CUBIST_PT_passes(CubistPanel, bpy.types.Panel):
    bl_label = "Passes"
    bl_parent_id = "CUBIST_PT_render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        col = layout.column(heading="Include")
        for toggle in ("pass_saliency", "pass_facet_ids", "pass_facets", "pass_segments", "pass_objects",
                       "pass_normals", "pass_depth"):
            col.prop(c, toggle)


class CUBIST_PT_output(CubistPanel, bpy.types.Panel):
    bl_label = "Output"
    bl_parent_id = "CUBIST_PT_render"

    def draw(self, context):
        c = context.scene.cubist
        layout = self.layout
        layout.use_property_split = True
        layout.prop(context.scene.render, "film_transparent", text="Transparent")
        layout.prop(c, "use_world_background")
        row = layout.row()
        row.active = not c.use_world_background or context.scene.world is None
        row.prop(c, "background")
        layout.prop(c, "shadows")
        layout.prop(c, "exposure")
        # The render thread reads the scene Blender evaluated for the render; Lock Interface
        # also keeps the interface from editing the scene while a frame renders.
        layout.prop(context.scene.render, "use_lock_interface")


classes = (
    CUBIST_OT_apply_preset,
    CUBIST_OT_preset_add,
    CUBIST_MT_presets,
    CUBIST_OT_recompute_layout,
    CUBIST_PT_render,
    CUBIST_PT_camera,
    CUBIST_PT_facets,
    CUBIST_PT_imprecision,
    CUBIST_PT_saliency,
    CUBIST_PT_painterly,
    CUBIST_PT_sampling,
    CUBIST_PT_passes,
    CUBIST_PT_output,
)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
