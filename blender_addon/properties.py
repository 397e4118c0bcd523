"""The Cubist settings of a scene (`scene.cubist`): one property per renderer setting, with
units and the thesis's recommended values in the tooltips. Defaults come from presets.DEFAULTS
(the renderer's own `analytic` values, read from renderer_presets.json);
mapping.settings_from_panel turns the properties into the settings JSON."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty, StringProperty

from . import presets
from .presets import DEFAULTS

D = DEFAULTS


def _update_passes(self, context):
    # Pass toggles change the passes Blender offers to the compositor.
    if context is not None and context.view_layer is not None:
        context.view_layer.update_render_passes()


def apply_look(props, values: dict) -> None:
    """Sets panel values, the preset first (its update sets the whole look)."""
    if "preset" in values:
        props.preset = values["preset"]
    for k, v in values.items():
        if k != "preset":
            setattr(props, k, v)


def _update_preset(self, context):
    # Choosing a preset sets every look value to the renderer's own (renderer_presets.json);
    # sampling, passes, files and the scene's choices stay.
    values = presets.renderer_preset_values(presets.enum_value(self.preset))
    for k, v in values.items():
        if k != "preset":
            setattr(self, k, v)


class CubistSettings(bpy.types.PropertyGroup):
    preset: EnumProperty(
        name="Preset",
        description="The renderer's preset (`cubist render --preset`). Choosing one sets the camera, facets, "
                    "imprecision and painterly values to the preset's; sampling, passes and files stay",
        items=[(presets.enum_id(name), label, desc) for name, (label, desc) in presets.PRESET_LABELS.items()],
        default=D["preset"], update=_update_preset)

    # ---- Sampling
    spp: IntProperty(name="Samples", description="Samples per pixel, stratified and seeded. 1 for previews, "
                     "4 (default) for finals, 16 for very clean facet edges", default=D["spp"], min=1,
                     soft_max=64, max=4096)
    seed: IntProperty(name="Seed", description="Seed of every random choice (sampling, facets, gradients): "
                      "same seed, same picture on any machine", default=D["seed"], min=0)
    animate_seed: BoolProperty(name="Animated Seed", description="Add the frame number to the seed. Off "
                               "(recommended for animation): what does not move stays identical between frames",
                               default=D["animate_seed"])

    # ---- Camera
    camera: EnumProperty(
        name="Camera",
        description="The camera model (thesis 4.2). The Blender camera gives position and direction",
        items=[("AUTO", "Auto", "Spherical, or cylindrical for tall scenes (height >= 1.6 x width)"),
               ("SPHERICAL", "Spherical", "Rays start on a sphere and converge on the focal centre (eq 4.2); "
                "the paper's preferred camera"),
               ("CYLINDRICAL", "Cylindrical", "Rays converge on a vertical focal line: standing figures"),
               ("PLANAR", "Planar", "Rays start on a plane and converge on a focal point (eq 4.1)"),
               ("PERSPECTIVE", "Perspective", "An ordinary pinhole camera (baseline)"),
               ("ORTHOGRAPHIC", "Orthographic", "Parallel rays (baseline)")],
        default=D["camera"])
    ambiguity: FloatProperty(
        name="Ambiguity", description="Convergence angle of the cubist camera, degrees: how far around the "
        "object one picture sees. The paper recommends 120-150 (default 140); 360 surrounds the object. "
        "Planar: below 180", default=D["ambiguity"], min=0.0, max=360.0, soft_min=60.0, precision=1)
    use_camera_lens: BoolProperty(
        name="Use Camera Lens", description="Perspective: the Blender camera's field of view instead of "
        "Ambiguity. Orthographic: its Orthographic Scale", default=D["use_camera_lens"])
    framing: EnumProperty(
        name="Framing", description="Where the focal centre goes when the camera gives no focus",
        items=[("FIT", "Fit", "Behind the scene's centre, so the whole scene fits the convergence angle"),
               ("CENTRE", "Centre", "At the centre of the scene's bounding box (the thesis's literal choice)")],
        default=D["framing"])
    use_camera_focus: BoolProperty(
        name="Use Camera Focus", description="The focal centre is the camera's depth-of-field focus: its Focus "
        "Object, else its Focus Distance when Depth of Field is enabled. Off, or neither set: Framing decides",
        default=D["use_camera_focus"])
    camera_size: FloatProperty(
        name="Camera Size", description="Planar camera plane height / orthographic view height / cylindrical "
        "band height, scene units. 0 = fit the scene", default=D["camera_size"], min=0.0, unit="LENGTH")
    fill: FloatProperty(
        name="Fill", description="Fraction of the view the scene fills when the focal centre is placed by Fit "
        "framing: of the convergence half-angles for cubist cameras, of the smaller image side otherwise. "
        "0 = automatic (0.8 for cubist cameras, 0.9 for the others)", default=D["fill"], min=0.0, max=1.0,
        subtype="FACTOR")

    # ---- Shading
    shadows: BoolProperty(name="Shadows", description="Cast one shadow ray per light per hit",
                          default=D["shadows"])
    exposure: FloatProperty(name="Exposure", description="Multiplier on the lights, after the automatic "
                            "exposure that makes any light units work. 1 = as exposed", default=D["exposure"],
                            min=0.0, soft_max=4.0)
    use_world_background: BoolProperty(
        name="World Background", description="The World's colour (its Background node, times strength) as the "
        "background; off: the colour below", default=D["use_world_background"])
    background: FloatVectorProperty(
        name="Background", description="Background colour, linear RGB (default: a warm canvas)",
        subtype="COLOR", size=3, min=0.0, soft_max=1.0, default=D["background"])

    # ---- Facets
    faceting: EnumProperty(
        name="Faceting", description="How the image is split into facets (thesis 4.3.1)",
        items=[("NONE", "None", "One facet: the unfaceted cubist view"),
               ("CONSTANT", "Constant", "A facet map image, each distinct colour a facet"),
               ("VORONOI", "Voronoi", "Nearest of k stratified random points"),
               ("PATCH", "Patch", "Random quadrilaterals painted until every pixel is covered"),
               ("SEGMENT", "Segment", "Normalized-cut segments of the pre-render selected by saliency "
                "(the paper's preferred method)")],
        default=D["faceting"])
    facet_map: StringProperty(name="Facet Map", description="Constant faceting: an image whose distinct colours "
                              "are the facets, scaled to the output", subtype="FILE_PATH", default=D["facet_map"])
    facet_count: IntProperty(name="Facets", description="Voronoi: number of facets k (paper: 150)",
                             default=D["facet_count"], min=1, soft_max=2000)
    grid_cells: IntProperty(name="Grid Cells", description="Voronoi: grid cells m the k points are stratified "
                            "over (paper: 15)", default=D["grid_cells"], min=1, soft_max=400)
    patch_count: IntProperty(name="Patches", description="Patch: number of quadrilaterals n_p of eq 4.3 "
                             "(paper: 80; more are added until every pixel is covered)",
                             default=D["patch_count"], min=1, soft_max=1000)
    occlusion: FloatProperty(name="Occlusion", description="Patch: occlusion ratio r_occ of eq 4.3 (paper: 3); "
                             "larger = larger, more overlapping patches", default=D["occlusion"], min=0.01,
                             soft_max=10.0)
    segments: StringProperty(name="Segments", description="Segment: segments per level, comma-separated "
                             "(paper: 5, 30, 120)", default=D["segments"])
    thresholds: StringProperty(name="Thresholds", description="Segment: mean-saliency threshold per level, 0-1, "
                               "one per level (paper: 0, 0.05, 0.08)", default=D["thresholds"])
    superpixels: IntProperty(name="Superpixels", description="Segment: superpixels the normalized cut groups "
                             "into segments; 0 = automatic (from the image size and the finest level)",
                             default=D["superpixels"], min=0, max=1000000, soft_max=5000)
    weight_colour: FloatProperty(name="Colour", description="Segment: weight of colour (CIELAB) differences "
                                 "in the affinity between superpixels", default=D["weight_colour"], min=0.0,
                                 soft_max=4.0)
    weight_normal: FloatProperty(name="Normal", description="Segment: weight of surface normal differences",
                                 default=D["weight_normal"], min=0.0, soft_max=4.0)
    weight_depth: FloatProperty(name="Depth", description="Segment: weight of relative depth differences",
                                default=D["weight_depth"], min=0.0, soft_max=4.0)
    weight_object: FloatProperty(name="Object", description="Segment: how far object boundaries cut the "
                                 "affinity, 0-1; 1 = segments never cross an object boundary (a level may then "
                                 "get more segments than asked)", default=D["weight_object"], min=0.0, max=1.0,
                                 subtype="FACTOR")
    weight_saliency: FloatProperty(name="Saliency", description="Segment: weight of saliency differences",
                                   default=D["weight_saliency"], min=0.0, soft_max=4.0)
    static_facets: BoolProperty(
        name="Static Facets", description="Compute the facet layout once, on the Layout Frame, save it in the "
        "layout folder and reuse it for every frame: camera and objects move, facets stay (thesis Ch. 6). "
        "A Segment layout is computed again when what the Layout Frame shows changes. Frame chunks rendered "
        "by separate processes or farm machines then match one run. Off: a new layout for every render",
        default=D["static_facets"])
    layout_frame: IntProperty(
        name="Layout Frame", description="The frame whose view computes the static facet layout. Every frame, "
        "and every farm chunk whatever its frame range, reuses this frame's layout", default=D["layout_frame"])
    layout_folder: StringProperty(
        name="Layout Folder", description="Where the facet layout and the saliency cache are kept. Empty: a "
        "'cubist' folder beside the .blend (share it with the render farm)", subtype="DIR_PATH",
        default=D["layout_folder"])
    layout_file: StringProperty(
        name="Layout File", description="Load this facet layout (.json or .png, e.g. saved by `cubist render "
        "--save-facets` or `cubist facets`) for every frame instead of computing one. Empty: computed "
        "(once, with Static Facets)", subtype="FILE_PATH", default=D["layout_file"])

    # ---- Spatial imprecision
    imprecision: EnumProperty(
        name="Imprecision", description="How each facet's view is re-aimed (thesis 4.3.2)",
        items=[("SALIENCY", "Saliency", "Towards the facet's saliency centre (eq 4.5; the paper's method)"),
               ("RANDOM", "Random", "Towards a random point within the discontinuity radius (user study "
                "baseline)"),
               ("NONE", "None", "Not re-aimed")],
        default=D["imprecision"])
    discontinuity: FloatProperty(
        name="Discontinuity", description="Largest shift from a facet's centre to its saliency centre, pixels at "
        "1000 px (scaled with the image). The paper recommends 50-200; 0 = facets not re-aimed",
        default=D["discontinuity"], min=0.0, soft_max=400.0)
    neighborhood: FloatProperty(
        name="Neighbourhood", description="Pixels outside a facet that still count for its saliency centre, "
        "pixels at 1000 px (paper: 0)", default=D["neighborhood"], min=0.0, soft_max=200.0)
    facet_projection: EnumProperty(
        name="Facet Rays", description="The rays of a re-aimed facet",
        items=[("CONVERGING", "Converging", "Keep converging on the facet's new focal point (discontinuity 0 = "
                "the unfaceted view)"),
               ("LINEAR", "Linear", "Size-keeping linear facets of eq 4.6, less warped (thesis 5.3)")],
        default=D["facet_projection"])
    facet_fov: FloatProperty(name="Facet FOV", description="Linear facets: field of view, degrees (eq 4.7); "
                             "0 = orthographic facets (paper's default)", default=D["facet_fov"], min=0.0,
                             max=179.0)

    # ---- Mesh saliency
    saliency_method: EnumProperty(
        name="Saliency Method", description="How mesh saliency's Gaussian means are evaluated",
        items=[("AUTO", "Auto", "Exact while the sums stay affordable (a few seconds), clustered above"),
               ("EXACT", "Exact", "The definition's exact sums, whatever the mesh's size"),
               ("CLUSTERED", "Clustered", "Clustered sums: fast on huge meshes, approximate")],
        default=D["saliency_method"])
    use_saliency_cache: BoolProperty(
        name="Saliency Cache", description="Keep each mesh's saliency on disk, keyed by its content: frames and "
        "farm machines compute a mesh's saliency once (the picture is the same either way)",
        default=D["use_saliency_cache"])
    saliency_cache: StringProperty(
        name="Cache Folder", description="Where the saliency cache is kept. Empty: 'saliency' in the Layout "
        "Folder", subtype="DIR_PATH", default=D["saliency_cache"])

    # ---- Painterly
    border_width: FloatProperty(
        name="Border Width", description="Facet border darkening distance md of eq 4.8, pixels at 1000 px; 0 = off",
        default=D["border_width"], min=0.0, soft_max=50.0)
    border_strength: FloatProperty(name="Border Strength", description="0 = no darkening, 1 = eq 4.8 as "
                                   "printed", default=D["border_strength"], min=0.0, max=1.0, subtype="FACTOR")
    silhouette_width: FloatProperty(
        name="Silhouette Width", description="Darkening of the background near objects, pixels at 1000 px; 0 = off",
        default=D["silhouette_width"], min=0.0, soft_max=50.0)
    silhouette_strength: FloatProperty(name="Silhouette Strength", description="0 = none, 1 = full",
                                       default=D["silhouette_strength"], min=0.0, max=1.0, subtype="FACTOR")
    palette: EnumProperty(
        name="Palette", description="A built-in palette mapped onto the picture's luminance (colour transfer, "
        "thesis 4.4)",
        items=[("NONE", "None", "Keep the rendered colours"),
               ("OCHRE", "Ochre", "Browns and ochres of Braque and Picasso, 1910"),
               ("GREY", "Grey", "Grisaille, 1911: warm blacks, brownish and cool greys"),
               ("BLUE_PERIOD", "Blue Period", "Picasso's blue period: Prussian blue to pale blue-grey"),
               ("OLIVE", "Olive", "Braque, 1908-09: olive and earth greens to pale ochre")],
        default=D["palette"])
    palette_image: StringProperty(name="Palette Image", description="A painting whose colours are mapped onto "
                                  "the luminance (overrides Palette)", subtype="FILE_PATH",
                                  default=D["palette_image"])
    colors: IntProperty(name="Colours", description="Quantise to this many colours; 0 = off, else 2-4096",
                        default=D["colors"], min=0, max=4096, soft_max=64)
    gradients: FloatProperty(name="Gradients", description="Fraction of facets that get a gradient overlay on "
                             "a corner, 0-1", default=D["gradients"], min=0.0, max=1.0, subtype="FACTOR")
    chiaroscuro: FloatProperty(name="Chiaroscuro", description="Per-facet variation of light direction and "
                               "intensity, 0-1; 0 = off", default=D["chiaroscuro"], min=0.0, max=1.0,
                               subtype="FACTOR")

    # ---- Passes
    pass_saliency: BoolProperty(name="Saliency", description="Per-pixel mesh saliency, 0-1 (pass 'Saliency')",
                                default=False, update=_update_passes)
    pass_facet_ids: BoolProperty(name="Facet Index", description="Facet id of each pixel, an integer (pass "
                                 "'Facet Index', for ID masks in the compositor)", default=False, update=_update_passes)
    pass_facets: BoolProperty(name="Facets", description="Facets as colours with facet and saliency centres "
                              "marked (pass 'Facets')", default=False, update=_update_passes)
    pass_segments: BoolProperty(name="Segments", description="Segment faceting's final layout as colours (pass "
                                "'Segments')", default=False, update=_update_passes)
    pass_objects: BoolProperty(name="Objects", description="Object ids as colours (pass 'Object Colors')",
                               default=False, update=_update_passes)
    pass_normals: BoolProperty(name="Normals", description="Shading normals as colours (pass 'Cubist Normal')",
                               default=False, update=_update_passes)
    pass_depth: BoolProperty(name="Depth", description="Hit distance, near = white (pass 'Cubist Depth')",
                             default=False, update=_update_passes)


PANEL_KEYS = tuple(DEFAULTS)


def panel_values(props) -> dict:
    """The panel's values as plain Python (enum identifiers, tuples for colours)."""
    out = {}
    for k in PANEL_KEYS:
        v = getattr(props, k)
        if k == "background":
            v = tuple(v)
        out[k] = v
    return out


classes = (CubistSettings,)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.cubist = bpy.props.PointerProperty(type=CubistSettings, name="Cubist")


def unregister():
    del bpy.types.Scene.cubist
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
