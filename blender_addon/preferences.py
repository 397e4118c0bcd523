"""Add-on preferences: where the `cubist` binary is (found automatically when empty)."""

import bpy

from . import runner


def _package():
    # `cubist` as a legacy add-on, `bl_ext.<repo>.cubist` as an extension.
    return __package__


class CubistPreferences(bpy.types.AddonPreferences):
    bl_idname = _package()

    binary_path: bpy.props.StringProperty(
        name="Cubist Binary",
        description="Path to the cubist executable (or its folder). Empty: found on PATH, bundled with the "
                    "add-on, or in the project's target/release",
        subtype="FILE_PATH",
        default="",
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "binary_path")
        try:
            found = runner.find_binary(bpy.path.abspath(self.binary_path) if self.binary_path else "")
            layout.label(text=f"Using {found}", icon="CHECKMARK")
        except runner.CubistError as e:
            layout.label(text=str(e), icon="ERROR")


classes = (CubistPreferences,)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
