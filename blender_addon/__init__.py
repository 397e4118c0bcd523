"""Cubist render engine for Blender: press F12 with the engine set to Cubist to paint the
scene in the manner of Analytical Cubism with the `cubist` renderer (see docs/blender.md).

The Blender-facing modules are imported in register() only, so `runner`, `mapping`,
`presets` and `schema` (no bpy) can be imported and tested in plain Python. The panel's
properties are built from `renderer_schema.json` (`cubist settings --schema`) when it registers."""

bl_info = {
    "name": "Cubist",
    "author": "cubist contributors",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "Properties > Render > Render Engine > Cubist",
    "description": "Renders scenes in the manner of Analytical Cubism: cubist cameras, facets, painterly effects",
    "category": "Render",
}


def _modules():
    from . import ahead, colour, engine, preferences, properties, turns, ui, viewport

    return (preferences, properties, colour, turns, engine, viewport, ahead, ui)


def register():
    for m in _modules():
        m.register()


def unregister():
    for m in reversed(_modules()):
        m.unregister()
