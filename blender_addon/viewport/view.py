"""What a 3D view shows, as the renderer's camera and settings (main thread): the view's own
matrix and lens, or the scene camera's frame when the view looks through it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from .. import export, mapping, preferences


@dataclass(frozen=True)
class View:
    """What a viewport shows, as plain values (tests make one without a window): the size of
    the image and where it goes in the region (x, y from the bottom left; drawn over
    draw_width x draw_height, the camera frame's size on screen, when set), and the camera."""

    width: int
    height: int
    camera: Optional[mapping.CameraFacts]
    x: int = 0
    y: int = 0
    through_camera: bool = False
    draw_width: int = 0
    draw_height: int = 0

    def rect(self) -> tuple:
        """Where the image goes in the region: (x, y, width, height)."""
        return self.x, self.y, self.draw_width or self.width, self.draw_height or self.height


def view_camera_facts(view_matrix, is_perspective: bool, lens: float, view_distance: float) -> mapping.CameraFacts:
    """The view of a 3D viewport not looking through a camera, as a camera: its inverse view
    matrix, and the projection Blender draws it with (BKE_camera_params_from_view3d: a 36 mm
    sensor at twice the zoom, so 72 mm; orthographic views span 2 x distance x 36 / lens)."""
    m = [list(r) for r in view_matrix.inverted()]
    if is_perspective:
        return mapping.CameraFacts(matrix_world=m, type="PERSP", lens=lens, sensor_width=72.0, sensor_height=48.0)
    return mapping.CameraFacts(matrix_world=m, type="ORTHO", ortho_scale=2.0 * view_distance * 36.0 / lens)


def camera_rect(scene, cam, region, region_3d) -> Optional[tuple]:
    """The scene camera's frame in the region (x, y, width, height), as drawn in camera view."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d

    corners = [cam.matrix_world @ v for v in cam.data.view_frame(scene=scene)]
    pts = [location_3d_to_region_2d(region, region_3d, c) for c in corners]
    if any(p is None for p in pts):
        return None
    xs, ys = [p.x for p in pts], [p.y for p in pts]
    x0, y0 = min(xs), min(ys)
    return x0, y0, max(xs) - x0, max(ys) - y0


def view_of(context, depsgraph) -> Optional[View]:
    """The View of the 3D view being drawn (None when its camera frame is off screen)."""
    region, r3d, space = context.region, context.region_data, context.space_data
    scene = depsgraph.scene_eval
    if r3d.view_perspective == "CAMERA" and scene.camera is not None:
        cam = export.scene_camera(depsgraph)
        rect = camera_rect(scene, cam, region, r3d)
        if rect is None or rect[2] < 2 or rect[3] < 2:
            return None
        r = scene.render
        rw, rh = mapping.render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
        # The render's aspect, at the frame's size on screen (at most the render's size), drawn
        # over the whole frame (a frame larger than the render shows it scaled up).
        w = max(1, min(rw, round(rect[2])))
        h = max(1, round(w * rh / rw))
        return View(w, h, export.camera_facts(cam), round(rect[0]), round(rect[1]), True,
                    max(1, round(rect[2])), max(1, round(rect[3])))
    facts = view_camera_facts(r3d.view_matrix, r3d.is_perspective, space.lens, r3d.view_distance)
    return View(region.width, region.height, facts)


def settings_for(scene, view: View) -> dict:
    """The settings of a view of `scene` (its panel, its world), at the view's size."""
    facts = mapping.SceneFacts(width=view.width, height=view.height, frame=scene.frame_current, camera=view.camera,
                               background=export.world_background(scene.world),
                               transparent=scene.render.film_transparent)
    settings = mapping.settings_from_panel(preferences.panel(scene.cubist), facts)
    settings["passes"] = []  # the view shows the picture only
    settings.pop("save_facets", None)
    return settings

