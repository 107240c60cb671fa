"""Squall Ocean: a Blender add-on whose ocean planes (and boat wakes) are computed by squalld.

Add > Mesh > Squall Ocean makes a grid object; at every frame change its vertices move to
squalld's FFT ocean tile at that frame's time (Ocean.GetTile: height and choppy displacement), plus,
when a boat object is set, the wake of an eWave session that the boat drives. Needs the squall
Python package (client/python) importable by Blender's Python, or its directory in the add-on's
preferences.
"""

bl_info = {
    "name": "Squall Ocean",
    "author": "squall",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Add > Mesh > Squall Ocean; View3D > Sidebar > Squall",
    "description": "FFT ocean surfaces and boat wakes streamed from a squalld daemon",
    "category": "Add Mesh",
}

import bpy  # noqa: E402  (Blender reads bl_info before the imports)

from . import scene, settings, ui  # noqa: E402


def register() -> None:
    for cls in settings.classes + ui.classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.squall_ocean = bpy.props.PointerProperty(type=settings.SquallOceanSettings)
    scene.register()
    ui.register()


def unregister() -> None:
    ui.unregister()
    scene.unregister()
    del bpy.types.Object.squall_ocean
    for cls in reversed(settings.classes + ui.classes):
        bpy.utils.unregister_class(cls)
