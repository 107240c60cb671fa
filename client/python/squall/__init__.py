"""squall: a Python client of squalld with numpy arrays.

    import squall

    with squall.Client("127.0.0.1:50051") as client:
        spec = squall.ocean.tile_spec([squall.ocean.layer(extent=200, n=128)])
        tile = client.ocean.tile(spec, time=1.0)
        tile["height"]          # numpy float32 array of shape (ny, nx), metres

Capabilities (attributes of Client; builders in the modules of the same name):
    client.ocean     squall.ocean     ocean tiles, streams of frames, surface samples
    client.ewave     squall.ewave     eWave sessions: step, run (bidirectional stream), state,
        restore
    client.clouds    squall.clouds    cloud volumes (.vdb) and ray-marched images
    client.textures  squall.textures  advected textures: frame streams and interactive steering

``squall.aio.Client`` is the asyncio flavour. Every failure the server reports raises
``squall.SquallError`` (``.code``: grpc.StatusCode, ``.message``: the server's message). The
messages themselves (generated from proto/squall/v1 at install time) are ``squall.v1.<name>_pb2``.
"""

from squall import clouds, ewave, ocean, textures
from squall._convert import array_to_field, field_to_array
from squall._errors import PlaintextTokenWarning, SquallError
from squall._results import (
    BakedVelocity,
    DeformFrame,
    EvolutionFrame,
    EWaveFrame,
    FieldSet,
    Image,
    Samples,
    TextureFrame,
    Tile,
    Volume,
)
from squall.client import Client, tls_credentials

__version__ = "0.1.0"

__all__ = [
    "Client",
    "tls_credentials",
    "SquallError",
    "PlaintextTokenWarning",
    "ocean",
    "ewave",
    "clouds",
    "textures",
    "Tile",
    "Samples",
    "EWaveFrame",
    "TextureFrame",
    "BakedVelocity",
    "DeformFrame",
    "Image",
    "Volume",
    "EvolutionFrame",
    "FieldSet",
    "array_to_field",
    "field_to_array",
    "__version__",
]
