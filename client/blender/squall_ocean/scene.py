"""Ocean objects in the scene: their grid meshes, the squalld connection, and the frame handler that
moves the vertices to squalld's surface at each frame's time."""

from __future__ import annotations

import sys
from typing import Any, Dict, Optional, Tuple

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import settings, surface

# Per ocean object (by name): the parameters its surface was made with, and the surface.
_surfaces: Dict[str, Tuple[Any, surface.OceanSurface]] = {}
_clients: Dict[Tuple[str, float], Any] = {}
errors: Dict[str, str] = {}  # the last failure per object, shown in the panel


def import_squall(python_path: str) -> Any:
    """The squall package, from Blender's Python path or from the preferences' directory."""
    if python_path and bpy.path.abspath(python_path) not in sys.path:
        sys.path.append(bpy.path.abspath(python_path))
    import squall

    return squall


def client(context: bpy.types.Context) -> Any:
    prefs = settings.preferences(context)
    key = (prefs.address, prefs.timeout)
    if key not in _clients:
        squall = import_squall(prefs.python_path)
        _clients[key] = squall.Client(prefs.address, timeout=prefs.timeout)
    return _clients[key]


def frame_rate(scene: bpy.types.Scene) -> float:
    return scene.render.fps / scene.render.fps_base


def scene_time(scene: bpy.types.Scene, obj: bpy.types.Object, frame: float) -> float:
    """Simulation time of an animation frame, s."""
    return obj.squall_ocean.time_offset + frame / frame_rate(scene)


def build_grid(mesh: bpy.types.Mesh, extent: float, n: int) -> None:
    """(n + 1)^2 vertices at rest, n^2 quads, and UVs spanning [0, 1] over the tile."""
    mesh.clear_geometry()
    rest = surface.rest_positions(extent, n)
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    corner = (j * (n + 1) + i).ravel()
    quads = np.stack([corner, corner + 1, corner + n + 2, corner + n + 1], axis=1)
    mesh.from_pydata(rest.tolist(), [], quads.tolist())
    uv = mesh.uv_layers.new(name="UVMap")
    loop_vertices = quads.ravel()
    uv.data.foreach_set("uv", (rest[loop_vertices, :2] / extent + 0.5).ravel())
    mesh.update()


def boat_pose(boat: bpy.types.Object, frame: float) -> Tuple[Any, float]:
    """World location and heading (rad) of the boat at a frame: its keyframes evaluated there when
    it has an action, else where it is now (parents and constraints: only their current effect)."""
    location, heading = boat.matrix_world.translation.copy(), boat.matrix_world.to_euler().z
    action = boat.animation_data.action if boat.animation_data else None
    if action is None or boat.parent is not None:
        return location, heading
    for axis in range(3):
        curve = action.fcurves.find("location", index=axis)
        if curve is not None:
            location[axis] = curve.evaluate(frame)
    curve = action.fcurves.find("rotation_euler", index=2)
    if curve is not None:
        heading = curve.evaluate(frame)
    return location, heading


def hull_function(scene: bpy.types.Scene, obj: bpy.types.Object) -> Optional[Any]:
    """time -> Hull in the ocean's frame, or None without a wake."""
    s = obj.squall_ocean
    if not s.wake or s.boat is None:
        return None
    boat, to_local = s.boat, obj.matrix_world.inverted()
    ocean_heading = obj.matrix_world.to_euler().z
    length = s.hull_length or boat.dimensions.x
    beam = s.hull_beam or boat.dimensions.y

    def hull_at(time: float) -> surface.Hull:
        frame = (time - s.time_offset) * frame_rate(scene)
        location, heading = boat_pose(boat, frame)
        local = to_local @ location
        return surface.Hull(local.x, local.y, heading - ocean_heading, length, beam)

    return hull_at


def surface_of(context: bpy.types.Context, obj: bpy.types.Object) -> surface.OceanSurface:
    """The object's surface, made again when its parameters or the connection changed."""
    s, prefs = obj.squall_ocean, settings.preferences(context)
    ocean = s.ocean_parameters()
    wake = s.wake_parameters() if s.wake and s.boat is not None else None
    key = (ocean, wake, prefs.address, prefs.timeout, s.time_offset, context.scene.frame_start)
    known = _surfaces.get(obj.name)
    if known is not None and known[0] == key:
        return known[1]
    if known is not None:
        known[1].close()
    start = scene_time(context.scene, obj, context.scene.frame_start)
    made = surface.OceanSurface(client(context), ocean, wake, start)
    _surfaces[obj.name] = (key, made)
    return made


def update(context: bpy.types.Context, obj: bpy.types.Object) -> None:
    """Moves the object's vertices to the surface at the scene's current (sub)frame."""
    scene = context.scene
    ocean = surface_of(context, obj)
    n = ocean.ocean.resolution
    if len(obj.data.vertices) != (n + 1) ** 2:
        build_grid(obj.data, ocean.ocean.extent, n)
    frame = scene.frame_current + scene.frame_subframe
    hull_at = hull_function(scene, obj)
    positions = ocean.positions(scene_time(scene, obj, frame), 1 / frame_rate(scene), hull_at)
    obj.data.vertices.foreach_set("co", positions.astype(np.float32).ravel())
    obj.data.update()
    errors.pop(obj.name, None)


def ocean_objects(scene: bpy.types.Scene) -> list:
    return [o for o in scene.objects if o.type == "MESH" and o.squall_ocean.is_ocean]


def update_safely(context: bpy.types.Context, obj: bpy.types.Object) -> bool:
    """update(), with a failure recorded for the panel and printed instead of raised."""
    try:
        update(context, obj)
        return True
    except (
        Exception
    ) as e:  # a playback or render must go on (squall.SquallError, grpc, ImportError)
        errors[obj.name] = str(e)
        print(f"squall ocean {obj.name}: {e}", file=sys.stderr)
        return False


def settings_changed(obj: bpy.types.Object, scene: bpy.types.Scene) -> None:
    if obj.squall_ocean.is_ocean:
        update_safely(bpy.context, obj)


@persistent
def on_frame_change(scene: bpy.types.Scene, depsgraph: Any = None) -> None:
    for obj in ocean_objects(scene):
        update_safely(bpy.context, obj)


def add_ocean(context: bpy.types.Context) -> Any:
    """A new ocean object at the origin with the default settings, moved to the current frame
    (a failure is recorded in `errors`: the object stays, flat, for a later refresh)."""
    mesh = bpy.data.meshes.new("Squall Ocean")
    obj = bpy.data.objects.new("Squall Ocean", mesh)
    context.collection.objects.link(obj)
    s = obj.squall_ocean
    build_grid(mesh, s.extent, s.resolution)
    s.is_ocean = True
    update_safely(context, obj)
    return obj


def forget(name: Optional[str] = None) -> None:
    """Closes the surfaces (their eWave sessions) of one object, or of all and the clients."""
    for key in [name] if name else list(_surfaces):
        known = _surfaces.pop(key, None)
        if known is not None:
            try:
                known[1].close()
            except Exception as e:  # the daemon may be gone already
                print(f"squall ocean {key}: {e}", file=sys.stderr)
    if name is None:
        for c in _clients.values():
            c.close()
        _clients.clear()


def register() -> None:
    bpy.app.handlers.frame_change_post.append(on_frame_change)


def unregister() -> None:
    if on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(on_frame_change)
    forget()
