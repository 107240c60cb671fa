"""Runs inside Blender (blender -b --factory-startup --python blender_scene.py -- ARGS): enables the
Squall Ocean add-on from the user scripts directory, builds two ocean planes against a real squalld
(one plain, one with a keyframed boat's wake, both from the same tile), plays the animation, and
writes what the evaluated meshes look like to an .npz for test_addon.py to judge.

Arguments: --address HOST:PORT --python-path DIR (the squall package) --out FILE.npz; the scene's
numbers come as a JSON object in --scene.
"""

import argparse
import json
import sys

import addon_utils
import bpy
import numpy as np


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    for name in ("--address", "--python-path", "--out", "--scene"):
        parser.add_argument(name, required=True)
    return parser.parse_args(sys.argv[sys.argv.index("--") + 1 :])


def evaluated_vertices(obj: bpy.types.Object) -> np.ndarray:
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    co = np.empty(3 * len(evaluated.data.vertices), np.float32)
    evaluated.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def add_boat(numbers: dict) -> bpy.types.Object:
    """A box hull moving along +x at constant speed, keyframed at the first and last frames."""
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    boat = bpy.context.object
    boat.name = "Boat"
    boat.scale = (numbers["hull_length"], numbers["hull_beam"], 1.0)
    bpy.context.view_layer.update()  # dimensions follow the scale
    for frame, x in (
        (numbers["frame_start"], numbers["boat_x0"]),
        (numbers["frame_end"], numbers["boat_x1"]),
    ):
        boat.location = (x, numbers["boat_y"], 0.0)
        boat.keyframe_insert("location", frame=frame)
    for curve in boat.animation_data.action.fcurves:
        for key in curve.keyframe_points:
            key.interpolation = "LINEAR"
    return boat


def add_ocean(numbers: dict) -> bpy.types.Object:
    """Add > Mesh > Squall Ocean, then the settings as a user sets them in the sidebar."""
    result = bpy.ops.squall.ocean_add()
    if result != {"FINISHED"}:
        raise RuntimeError(f"squall.ocean_add: {result}")
    obj = bpy.context.object
    for name in ("extent", "resolution", "spectrum", "wind_speed", "wind_direction"):
        setattr(obj.squall_ocean, name, numbers[name])
    for name in ("choppiness", "seed"):
        setattr(obj.squall_ocean, name, numbers[name])
    return obj


def main() -> None:
    args = arguments()
    numbers = json.loads(args.scene)
    bpy.ops.preferences.addon_enable(module="squall_ocean")
    enabled = addon_utils.check("squall_ocean")
    prefs = bpy.context.preferences.addons["squall_ocean"].preferences
    prefs.address, prefs.python_path = args.address, args.python_path

    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = numbers["fps"], 1.0
    scene.frame_start, scene.frame_end = numbers["frame_start"], numbers["frame_end"]
    scene.frame_set(numbers["frame_start"])
    plain = add_ocean(numbers)
    boat = add_boat(numbers)
    waked = add_ocean(numbers)
    s = waked.squall_ocean
    s.wake_resolution, s.substeps, s.source_scale = (
        numbers["wake_resolution"],
        numbers["substeps"],
        1.0,
    )
    s.boat, s.wake = boat, True

    out = {"enabled": np.array(enabled)}
    for frame in range(numbers["frame_start"], numbers["frame_end"] + 1):
        scene.frame_set(frame)
        if frame in numbers["recorded_frames"]:
            out[f"plain_{frame}"] = evaluated_vertices(plain)
            out[f"waked_{frame}"] = evaluated_vertices(waked)
    back = numbers["revisited_frame"]
    scene.frame_set(back)  # backwards: the wake starts again and catches up
    out[f"revisited_{back}"] = evaluated_vertices(waked)
    prefs.address = "127.0.0.1:1"  # nothing listens there: the refresh fails with a message
    bpy.context.view_layer.objects.active = plain
    try:
        out["refresh"] = np.array(str(bpy.ops.squall.ocean_refresh()))
    except RuntimeError as e:  # bpy.ops raises an operator's ERROR report
        out["refresh"] = np.array(str(e))
    np.savez(args.out, **out)


try:
    main()
except Exception:
    import traceback

    traceback.print_exc()
    sys.exit(1)
