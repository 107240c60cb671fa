"""Operators (add an ocean, refresh it) and the sidebar panel (View3D > Sidebar > Squall)."""

from __future__ import annotations

import bpy

from . import scene, settings


class SQUALL_OT_ocean_add(bpy.types.Operator):
    """Add an ocean plane whose vertices follow squalld's FFT ocean at every frame (its settings:
    the Squall tab of the sidebar)"""

    bl_idname = "squall.ocean_add"
    bl_label = "Squall Ocean"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context: bpy.types.Context) -> set:
        obj = scene.add_ocean(context)
        context.view_layer.objects.active = obj
        if obj.name in scene.errors:  # the plane stays flat until a refresh succeeds
            self.report({"WARNING"}, f"squall: {scene.errors[obj.name]}")
        return {"FINISHED"}


class SQUALL_OT_ocean_refresh(bpy.types.Operator):
    """Ask squalld again for the active ocean at the current frame (after a reconnect)"""

    bl_idname = "squall.ocean_refresh"
    bl_label = "Refresh"

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        return context.object is not None and context.object.squall_ocean.is_ocean

    def execute(self, context: bpy.types.Context) -> set:
        scene.forget(context.object.name)
        if not scene.update_safely(context, context.object):
            self.report({"ERROR"}, f"squall: {scene.errors[context.object.name]}")
            return {"CANCELLED"}
        return {"FINISHED"}


class SQUALL_PT_ocean(bpy.types.Panel):
    bl_label = "Squall Ocean"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Squall"

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        layout.prop(settings.preferences(context), "address")
        obj = context.object
        if obj is None or not obj.squall_ocean.is_ocean:
            layout.operator(SQUALL_OT_ocean_add.bl_idname, icon="MOD_OCEAN")
            return
        s = obj.squall_ocean
        for name in ("extent", "resolution", "spectrum", "wind_speed", "wind_direction"):
            layout.prop(s, name)
        for name in ("choppiness", "seed", "time_offset", "wake"):
            layout.prop(s, name)
        if s.wake:
            box = layout.box()
            for name in ("boat", "wake_resolution", "source_scale", "substeps"):
                box.prop(s, name)
            box.prop(s, "hull_length")
            box.prop(s, "hull_beam")
        layout.operator(SQUALL_OT_ocean_refresh.bl_idname, icon="FILE_REFRESH")
        if obj.name in scene.errors:
            layout.label(text=scene.errors[obj.name], icon="ERROR")


def menu_add(self: bpy.types.Menu, context: bpy.types.Context) -> None:
    self.layout.operator(SQUALL_OT_ocean_add.bl_idname, icon="MOD_OCEAN")


classes = (SQUALL_OT_ocean_add, SQUALL_OT_ocean_refresh, SQUALL_PT_ocean)


def register() -> None:
    bpy.types.VIEW3D_MT_mesh_add.append(menu_add)


def unregister() -> None:
    bpy.types.VIEW3D_MT_mesh_add.remove(menu_add)
