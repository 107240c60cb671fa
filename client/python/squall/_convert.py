"""numpy arrays and Python values <-> squall.v1 messages.

- Fields (common.proto): little-endian float32 or float16, x fastest. A 2D field of nx x ny
  values is the array of shape (ny, nx) (row j = y index j); a 3D field the array of shape
  (nz, ny, nx).
- Enums take their full name ("SPECTRUM_MODEL_JONSWAP"), their short name without the enum's
  prefix in any case with "-" for "_" ("jonswap", "pierson-moskowitz"), a unique prefix of a
  short name ("lagrangian" for TEXTURE_METHOD_LAGRANGIAN_GRIDS), or the number.
- Messages take the message itself, or a mapping of field name -> value, converted recursively:
  Field from an array, Vec3 / Vec2 from a sequence of numbers, SimTime from a number of seconds.
"""

from __future__ import annotations

from typing import Any, Dict, Iterable, Mapping, Optional, Sequence, Tuple, Type, TypeVar, Union

import numpy as np
from google.protobuf import descriptor as _descriptor
from google.protobuf.message import Message

from squall._pb import common_pb2

M = TypeVar("M", bound=Message)

ArrayLike = Union[np.ndarray, Sequence[Any]]
FieldLike = Union[np.ndarray, common_pb2.Field, Sequence[Any]]
Vec3Like = Union[common_pb2.Vec3, Sequence[float]]

_NUMPY_DTYPE: Dict[int, np.dtype] = {
    common_pb2.DTYPE_UNSPECIFIED: np.dtype("<f4"),
    common_pb2.DTYPE_FLOAT32: np.dtype("<f4"),
    common_pb2.DTYPE_FLOAT16: np.dtype("<f2"),
}


# -------------------------------------------------------------------------------------------------
# Enums


def _enum_prefix(enum: _descriptor.EnumDescriptor) -> str:
    zero = enum.values_by_number.get(0)
    if zero is not None and zero.name.endswith("UNSPECIFIED"):
        return zero.name[: -len("UNSPECIFIED")]
    return ""


def short_names(enum: _descriptor.EnumDescriptor) -> Tuple[str, ...]:
    """The values of an enum without its prefix, lower case: ("phillips", "jonswap", ...)."""
    prefix = _enum_prefix(enum)
    return tuple(
        v.name[len(prefix) :].lower() for v in enum.values if v.number != 0 or prefix == ""
    )


def enum_value(
    enum: _descriptor.EnumDescriptor, value: Union[str, int], path: str = "value"
) -> Any:
    """The number (an int) of an enum value given as described in the module docstring."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{path} = {value!r}: want a {enum.name} name or number")
    if isinstance(value, (int, np.integer)):
        if int(value) in enum.values_by_number:
            return int(value)
        raise ValueError(f"{path} = {value}: not a {enum.full_name} number")
    if not isinstance(value, str):
        raise TypeError(f"{path} = {value!r}: want a {enum.name} name or number")
    names = enum.values_by_name
    if value in names:
        return names[value].number
    prefix = _enum_prefix(enum)
    key = prefix + value.strip().upper().replace("-", "_").replace(" ", "_")
    if key in names:
        return names[key].number
    matches = [name for name in names if name.startswith(key) and name != prefix + "UNSPECIFIED"]
    if len(matches) == 1:
        return names[matches[0]].number
    raise ValueError(
        f"{path} = {value!r}: want one of {', '.join(short_names(enum))} ({enum.full_name})"
    )


def enum_name(enum: _descriptor.EnumDescriptor, number: int) -> str:
    """The short, lower-case name of an enum value ("jonswap"); the number as text if unknown."""
    value = enum.values_by_number.get(number)
    if value is None:
        return str(number)
    return value.name[len(_enum_prefix(enum)) :].lower()


def dtype_value(dtype: Union[str, int, np.dtype, type, None], path: str = "dtype") -> Any:
    """squall.v1.DType from "float32" / "float16", np.float32 / np.float16, or the enum."""
    if dtype is None:
        return common_pb2.DTYPE_FLOAT32
    if isinstance(dtype, (np.dtype, type)):
        kind = np.dtype(dtype)
        if kind == np.float32:
            return common_pb2.DTYPE_FLOAT32
        if kind == np.float16:
            return common_pb2.DTYPE_FLOAT16
        raise ValueError(f"{path} = {kind}: want float32 or float16")
    return enum_value(common_pb2.DType.DESCRIPTOR, dtype, path)


# -------------------------------------------------------------------------------------------------
# Fields


def field_to_array(field: common_pb2.Field, path: str = "field") -> np.ndarray:
    """The values of a Field as a writable array of shape (ny, nx) (2D) or (nz, ny, nx) (3D).

    float32 fields give float32 arrays, float16 fields float16 arrays (exact;
    ``.astype(np.float32)`` widens them).
    """
    dtype = _NUMPY_DTYPE.get(field.dtype)
    if dtype is None:
        raise ValueError(f"{path}.dtype = {field.dtype}: not DTYPE_FLOAT32 or DTYPE_FLOAT16")
    shape: Tuple[int, ...] = (
        (field.ny, field.nx) if field.nz <= 1 else (field.nz, field.ny, field.nx)
    )
    count = int(np.prod(shape, dtype=np.int64))
    if len(field.data) != count * dtype.itemsize:
        raise ValueError(
            f"{path}.data has {len(field.data)} bytes, "
            f"want nx * ny * max(nz, 1) * {dtype.itemsize} = {count * dtype.itemsize}"
        )
    return (
        np.frombuffer(field.data, dtype=dtype)
        .reshape(shape)
        .astype(dtype.newbyteorder("="), copy=True)
    )


def array_to_field(
    values: ArrayLike,
    name: str = "",
    unit: str = "",
    *,
    dtype: Union[str, int, np.dtype, type, None] = None,
    spacing: Optional[Union[float, Sequence[float]]] = None,
    origin: Optional[Sequence[float]] = None,
    path: str = "field",
) -> common_pb2.Field:
    """A Field holding `values`, an array of shape (ny, nx) or (nz, ny, nx), x fastest.

    Args:
        values: the grid; row j is y index j.
        name, unit: the Field's name and unit (requests ignore them).
        dtype: "float32" or "float16"; None: float16 arrays stay float16, others become float32.
        spacing: sample spacing along x, y (z), metres (or du): a number for all axes or a
            sequence; None leaves it unset (squall's input maps ignore it: the message holding them
            places them).
        origin: world position of sample (0, 0, 0); None leaves it unset.
    """
    array = np.asarray(values)
    if array.ndim not in (2, 3):
        raise ValueError(
            f"{path}: want an array of shape (ny, nx) or (nz, ny, nx), got shape {array.shape}"
        )
    if array.dtype.kind not in "fiub":
        raise TypeError(f"{path}: want numbers, got an array of {array.dtype}")
    kind: Any
    if dtype is None:
        kind = common_pb2.DTYPE_FLOAT16 if array.dtype == np.float16 else common_pb2.DTYPE_FLOAT32
    else:
        kind = dtype_value(dtype, f"{path}.dtype")
    field = common_pb2.Field(name=name, unit=unit, dtype=kind)
    if array.ndim == 3:
        field.nz, field.ny, field.nx = array.shape
    else:
        field.ny, field.nx = array.shape
    field.data = np.ascontiguousarray(array, dtype=_NUMPY_DTYPE[kind]).tobytes()
    if spacing is not None:
        values = np.atleast_1d(np.asarray(spacing, dtype=np.float64))
        s = [float(values[0])] * 3 if values.size == 1 else [float(v) for v in values]
        field.spacing.CopyFrom(vec3(s, f"{path}.spacing"))
    if origin is not None:
        field.origin.CopyFrom(vec3(origin, f"{path}.origin"))
    return field


def to_field(value: FieldLike, path: str = "field") -> common_pb2.Field:
    """A Field from a Field message or an array (see array_to_field)."""
    if isinstance(value, common_pb2.Field):
        return value
    return array_to_field(value, path=path)


# -------------------------------------------------------------------------------------------------
# Small messages


def vec3(value: Vec3Like, path: str = "vec3") -> common_pb2.Vec3:
    """A Vec3 from (x, y) or (x, y, z) (z = 0 when left out), or a Vec3."""
    if isinstance(value, common_pb2.Vec3):
        return value
    if isinstance(value, Mapping):
        return to_message(common_pb2.Vec3, value, path)
    items = [float(v) for v in np.asarray(value, dtype=np.float64).ravel()]
    if len(items) not in (2, 3):
        raise ValueError(f"{path}: want (x, y) or (x, y, z), got {len(items)} numbers")
    return common_pb2.Vec3(x=items[0], y=items[1], z=items[2] if len(items) == 3 else 0.0)


def points_to_vec3(points: ArrayLike, path: str = "points") -> Iterable[common_pb2.Vec3]:
    """Vec3 messages from an array of shape (n, 2) or (n, 3)."""
    array = np.asarray(points, dtype=np.float64)
    if array.ndim == 1 and array.size in (2, 3):
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] not in (2, 3):
        raise ValueError(f"{path}: want an array of shape (n, 2) or (n, 3), got {array.shape}")
    if array.shape[1] == 2:
        return [common_pb2.Vec3(x=x, y=y) for x, y in array.tolist()]
    return [common_pb2.Vec3(x=x, y=y, z=z) for x, y, z in array.tolist()]


def _special(cls: Type[M], value: Any, path: str) -> Optional[M]:
    """Shorthands of some message types (see the module docstring), else None."""
    name = cls.DESCRIPTOR.full_name
    if name == "squall.v1.Field" and not isinstance(value, Mapping):
        return array_to_field(value, path=path)  # type: ignore[return-value]
    if name == "squall.v1.Vec3" and not isinstance(value, Mapping):
        return vec3(value, path)  # type: ignore[return-value]
    if name == "squall.v1.Vec2" and not isinstance(value, Mapping):
        items = [float(v) for v in np.asarray(value, dtype=np.float64).ravel()]
        if len(items) != 2:
            raise ValueError(f"{path}: want (x, y), got {len(items)} numbers")
        return cls(x=items[0], y=items[1])
    if name == "squall.v1.SimTime" and isinstance(value, (int, float, np.integer, np.floating)):
        return cls(seconds=float(value))
    return None


def _scalar(fd: _descriptor.FieldDescriptor, value: Any, path: str) -> Any:
    if fd.enum_type is not None:
        return enum_value(fd.enum_type, value, path)
    if fd.type == fd.TYPE_BYTES:
        return bytes(value)
    if fd.type == fd.TYPE_STRING:
        if not isinstance(value, str):
            raise TypeError(f"{path} = {value!r}: want a string")
        return value
    if fd.type == fd.TYPE_BOOL:
        return bool(value)
    if fd.cpp_type in (fd.CPPTYPE_DOUBLE, fd.CPPTYPE_FLOAT):
        return float(value)
    if isinstance(value, (float, np.floating)) and not float(value).is_integer():
        raise ValueError(f"{path} = {value!r}: want an integer")
    return int(value)


def set_fields(message: Message, values: Mapping[str, Any], path: str) -> None:
    """Sets the fields of `message` from a mapping (None values leave a field unset)."""
    descriptor = message.DESCRIPTOR
    for key, value in values.items():
        fd = descriptor.fields_by_name.get(key)
        if fd is None:
            known = ", ".join(f.name for f in descriptor.fields)
            raise TypeError(
                f"{path}: {descriptor.full_name} has no field {key!r} (fields: {known})"
            )
        if value is None:
            continue
        where = f"{path}.{key}"
        if fd.label == fd.LABEL_REPEATED:
            container = getattr(message, key)
            del container[:]
            if fd.message_type is not None:
                for i, item in enumerate(value):
                    sub = container.add()
                    sub.CopyFrom(to_message(type(sub), item, f"{where}[{i}]"))
            else:
                items = (
                    np.asarray(value).ravel().tolist()
                    if isinstance(value, np.ndarray)
                    else list(value)
                )
                container.extend(
                    _scalar(fd, item, f"{where}[{i}]") for i, item in enumerate(items)
                )
        elif fd.message_type is not None:
            sub = getattr(message, key)
            sub.CopyFrom(to_message(type(sub), value, where))
            sub.SetInParent()  # present even when empty (oneof members, "use the defaults")
        else:
            setattr(message, key, _scalar(fd, value, where))


def to_message(cls: Type[M], value: Any, path: str = "request") -> M:
    """A `cls` from a `cls`, a mapping of its fields, or a shorthand (see the module docstring)."""
    if isinstance(value, cls):
        return value
    if value is None:
        return cls()
    special = _special(cls, value, path)
    if special is not None:
        return special
    if isinstance(value, Message):
        raise TypeError(
            f"{path}: want {cls.DESCRIPTOR.full_name}, got {value.DESCRIPTOR.full_name}"
        )
    if not isinstance(value, Mapping):
        raise TypeError(
            f"{path}: want {cls.DESCRIPTOR.full_name} or a mapping of its fields, got {value!r}"
        )
    message = cls()
    set_fields(message, value, path)
    return message


def message_from(cls: Type[M], base: Any, path: str, **fields: Any) -> M:
    """`base` (a message, a mapping or None) as a `cls`, plus the keyword fields not None."""
    message = cls()
    message.CopyFrom(to_message(cls, base, path))
    set_fields(message, {k: v for k, v in fields.items() if v is not None}, path)
    return message


def repeated_per(values: Union[float, Sequence[float], None], count: int) -> Optional[list]:
    """A scalar repeated `count` times, a sequence as a list, None as None."""
    if values is None:
        return None
    if np.isscalar(values):
        return [float(values)] * count  # type: ignore[arg-type]
    return [float(v) for v in values]  # type: ignore[union-attr]


def fields_dict(fields: Iterable[common_pb2.Field], path: str = "fields") -> Dict[str, np.ndarray]:
    """name -> array for Fields (see field_to_array)."""
    return {f.name: field_to_array(f, f"{path}.{f.name}") for f in fields}
