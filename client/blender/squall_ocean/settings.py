"""The add-on's preferences (where squalld is) and each ocean object's settings (Object.squall_ocean)."""

from __future__ import annotations

import math

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from . import surface

SPECTRUM_ITEMS = [
    ("jonswap", "JONSWAP", "Hasselmann et al. 1973: a fetch-limited sea"),
    ("pierson_moskowitz", "Pierson-Moskowitz", "A fully developed sea"),
    ("phillips", "Phillips", "Tessendorf's Phillips spectrum"),
    ("tma", "TMA", "JONSWAP in finite depth"),
]
assert tuple(i[0] for i in SPECTRUM_ITEMS) == surface.SPECTRA


def _changed(settings: "SquallOceanSettings", context: bpy.types.Context) -> None:
    from . import scene  # scene imports this module

    scene.settings_changed(settings.id_data, context.scene)


class SquallPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    address: StringProperty(
        name="Address",
        description="squalld's gRPC address, host:port",
        default="127.0.0.1:50051",
    )
    python_path: StringProperty(
        name="squall package directory",
        description="A directory that holds the squall Python package (for example a venv's "
        "site-packages); empty: Blender's own Python path",
        subtype="DIR_PATH",
        default="",
    )
    timeout: FloatProperty(
        name="Timeout", description="Deadline of each call, s", default=60.0, min=1.0
    )

    def draw(self, context: bpy.types.Context) -> None:
        self.layout.prop(self, "address")
        self.layout.prop(self, "python_path")
        self.layout.prop(self, "timeout")


class SquallOceanSettings(bpy.types.PropertyGroup):
    """The tile (one squall ocean layer) and the optional boat wake of one mesh object."""

    is_ocean: BoolProperty(default=False, options={"HIDDEN"})
    extent: FloatProperty(
        name="Size",
        description="Side L of the periodic tile, m",
        default=200.0,
        min=1.0,
        max=1.0e5,
        unit="LENGTH",
        update=_changed,
    )
    resolution: IntProperty(
        name="Resolution",
        description="FFT samples per side (even); the mesh has one more " "vertex per side",
        default=128,
        min=4,
        max=2048,
        step=2,
        update=_changed,
    )
    spectrum: EnumProperty(
        name="Spectrum", items=SPECTRUM_ITEMS, default="jonswap", update=_changed
    )
    wind_speed: FloatProperty(
        name="Wind speed",
        description="U10, m/s",
        default=10.0,
        min=0.1,
        max=100.0,
        update=_changed,
    )
    wind_direction: FloatProperty(
        name="Wind direction",
        description="Where the wind blows to, counter-clockwise from +X",
        default=0.0,
        subtype="ANGLE",
        update=_changed,
    )
    choppiness: FloatProperty(
        name="Choppiness",
        description="lambda of the horizontal displacement",
        default=1.0,
        min=-10.0,
        max=10.0,
        update=_changed,
    )
    seed: IntProperty(name="Seed", default=1, min=0, update=_changed)
    time_offset: FloatProperty(
        name="Time offset",
        description="Simulation time at frame 0, s",
        default=0.0,
        update=_changed,
    )
    wake: BoolProperty(
        name="Boat wake",
        description="Add the eWave wake of the boat object",
        default=False,
        update=_changed,
    )
    boat: PointerProperty(
        name="Boat",
        type=bpy.types.Object,
        description="The object whose hull makes the wake",
        update=_changed,
    )
    wake_resolution: IntProperty(
        name="Wake resolution",
        description="eWave cells per side over the tile",
        default=128,
        min=8,
        max=2048,
        update=_changed,
    )
    source_scale: FloatProperty(
        name="Hull source",
        description="S0: the hull's height source, m/s",
        default=1.0,
        min=0.0,
        max=100.0,
        update=_changed,
    )
    substeps: IntProperty(
        name="Substeps",
        description="eWave steps per frame",
        default=2,
        min=1,
        max=64,
        update=_changed,
    )
    hull_length: FloatProperty(
        name="Hull length",
        description="m; 0: the boat's X dimension",
        default=0.0,
        min=0.0,
        unit="LENGTH",
        update=_changed,
    )
    hull_beam: FloatProperty(
        name="Hull beam",
        description="m; 0: the boat's Y dimension",
        default=0.0,
        min=0.0,
        unit="LENGTH",
        update=_changed,
    )

    def ocean_parameters(self) -> surface.OceanParameters:
        return surface.OceanParameters(
            extent=self.extent,
            resolution=self.resolution + self.resolution % 2,
            spectrum=self.spectrum,
            wind_speed=self.wind_speed,
            wind_direction=math.remainder(self.wind_direction, 2 * math.pi),
            choppiness=self.choppiness,
            seed=self.seed,
        )

    def wake_parameters(self) -> surface.WakeParameters:
        return surface.WakeParameters(
            resolution=self.wake_resolution,
            source_scale=self.source_scale,
            substeps=self.substeps,
        )


classes = (SquallPreferences, SquallOceanSettings)


def preferences(context: bpy.types.Context) -> SquallPreferences:
    return context.preferences.addons[__package__].preferences
