"""numpy arrays and Python values <-> squall.v1 messages.

- Fields (common.proto): little-endian float32 or float16, x fastest. A 2D field of nx x ny
  values is the array of shape (ny, nx) (row j = y index j); a 3D field the array of shape
  (nz, ny, nx).
- Enums take their full name ("SPECTRUM_MODEL_JONSWAP"), their short name without the enum's
  prefix in any case with "-" for "_" ("jonswap", "pierson-moskowitz"), a unique prefix of a
  short name ("lagrangian" for TEXTURE_METHOD_LAGRANGIAN_GRIDS), or the number.
- Messages take the message itself, or a mapping of field name -> value, converted recursively:
  Field from an array, Vec3 / Vec2 from a sequence of numbers, SimTime from a number of seconds.
- Scalars are checked before anything is sent (``number``, ``integer``, ``flag``, ``byte_string``):
  a number field takes an int, a float or a numpy number (not a bool or a string); an integer
  field also a float holding an integer (2.0), within the field's wire range (uint32: [0, 2**32 -
  1]); a bool field True or False (numpy bools too, not 0 / 1 or strings such as "off"); a bytes
  field a bytes-like object. Mistakes raise TypeError (the wrong kind of value) or ValueError (the
  right kind, out of range) naming the argument or field path and what is wanted, e.g.
  ``layer.nx = 2.5: want an integer``. A size or a count has no "unset" (None would be sent as
  0): None for one is a TypeError too.
- Arrays (fields, points, vertices, matrices) take real numbers: an array of complex, object or
  string values is a TypeError naming the argument (``real_array``), not cast to float.
"""

from __future__ import annotations

import numbers
from typing import (
    Any,
    Dict,
    Iterable,
    List,
    Mapping,
    Optional,
    Sequence,
    Tuple,
    Type,
    TypeVar,
    Union,
    cast,
)

import numpy as np
from google.protobuf import descriptor as _descriptor
from google.protobuf.message import Message
from numpy.typing import NDArray

from squall._pb import common_pb2

M = TypeVar("M", bound=Message)

ArrayLike = Union[NDArray[Any], Sequence[Any]]
FieldLike = Union[NDArray[Any], common_pb2.Field, Sequence[Any]]
Vec3Like = Union[common_pb2.Vec3, Sequence[float]]

# The numpy dtype of each Field dtype (Fields hold float32 or float16 values).
_NUMPY_DTYPE: Dict[int, np.dtype[np.floating[Any]]] = {
    common_pb2.DTYPE_UNSPECIFIED: np.dtype("<f4"),
    common_pb2.DTYPE_FLOAT32: np.dtype("<f4"),
    common_pb2.DTYPE_FLOAT16: np.dtype("<f2"),
}

UINT32_MAX = 2**32 - 1
UINT64_MAX = 2**64 - 1
FLOAT32_MAX = float(np.finfo(np.float32).max)

_FD = _descriptor.FieldDescriptor
# The values an integer field's wire type holds.
_INTEGER_RANGES: Dict[int, Tuple[int, int]] = {
    _FD.CPPTYPE_INT32: (-(2**31), 2**31 - 1),
    _FD.CPPTYPE_UINT32: (0, UINT32_MAX),
    _FD.CPPTYPE_INT64: (-(2**63), 2**63 - 1),
    _FD.CPPTYPE_UINT64: (0, UINT64_MAX),
}


# -------------------------------------------------------------------------------------------------
# Arguments: each checked before anything is sent, with a TypeError (the wrong kind of value) or a
# ValueError (the right kind, out of range) that names the argument or field and what is wanted.


def shown(value: Any) -> str:
    """repr(value) for an error message: on one line, cut to 60 characters (an array's may be
    long)."""
    text = " ".join(repr(value).split())
    return text if len(text) <= 60 else text[:56] + " ..."


def _plain(value: Any) -> Any:
    """A 0-d numpy array as its Python scalar, anything else as it is."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return value.item()
    return value


def is_number(value: Any) -> bool:
    """Whether `value` is one number (an int, a float, a numpy number or a 0-d array of one)."""
    value = _plain(value)
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def number(value: Any, path: str) -> float:
    """`value` as a float: an int, a float or a numpy number; not a bool, a string or None."""
    value = _plain(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{path} = {shown(value)}: want a number")
    try:
        return float(value)
    except OverflowError:  # an int past float's range
        raise ValueError(f"{path} = {shown(value)}: want a number in float's range") from None


def float32(value: Any, path: str) -> float:
    """`value` as a float that float32 holds: infinite and NaN ones as given, finite ones that
    round to a finite float32 (to at most FLOAT32_MAX; larger ones would be sent as inf)."""
    result = number(value, path)
    with np.errstate(over="ignore"):
        rounds_to_inf = np.isfinite(result) and np.isinf(np.float32(result))
    if rounds_to_inf:
        raise ValueError(f"{path} = {result!r}: beyond float32, want |value| <= {FLOAT32_MAX:g}")
    return result


def integer(value: Any, path: str, low: int, high: Optional[int] = None) -> int:
    """`value` as an int in [low, high] (high None: no upper bound): an int, a numpy integer or a
    float holding an integer (2.0); not a bool, a string or None."""
    value = _plain(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{path} = {shown(value)}: want an integer")
    if isinstance(value, numbers.Integral):
        result = int(value)
    elif float(value).is_integer():
        result = int(float(value))
    else:
        raise ValueError(f"{path} = {float(value)!r}: want an integer")
    if result < low or (high is not None and result > high):
        bounds = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise ValueError(f"{path} = {result}: want an integer {bounds}")
    return result


def flag(value: Any, path: str) -> bool:
    """`value` as a bool: True or False, or a numpy bool; not a number or a string ("off" is
    no False)."""
    value = _plain(value)
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError(f"{path} = {shown(value)}: want True or False")


def byte_string(value: Any, path: str) -> bytes:
    """`value` as bytes: bytes, a bytearray or another buffer (not a number, which bytes() would
    make that many zero bytes, nor a str)."""
    try:
        return bytes(memoryview(value))
    except TypeError:
        raise TypeError(f"{path} = {shown(value)}: want bytes") from None


def sequence(value: Any, path: str, want: str) -> List[Any]:
    """The items of a list, a tuple, an array (its rows) or another iterable; TypeError naming
    `path` and `want` for None, a number, a str, bytes or a mapping."""
    scalar = isinstance(value, np.ndarray) and value.ndim == 0
    text = isinstance(value, (str, bytes, bytearray, Mapping))
    if scalar or text or not isinstance(value, Iterable):
        raise TypeError(f"{path} = {shown(value)}: want {want}")
    return list(value)


def items_of(value: Any, path: str, counts: Sequence[int], want: str) -> List[Any]:
    """The items of a sequence (see ``sequence``) of one of the lengths `counts`; ValueError naming
    `path` and `want` for another length."""
    items = sequence(value, path, want)
    if len(items) not in counts:
        raise ValueError(f"{path} = {shown(value)}: want {want}")
    return items


def floats(
    value: Any, path: str, want: str, counts: Optional[Sequence[int]] = None
) -> List[float]:
    """The numbers of a sequence or an array (raveled), of one of the lengths `counts` (None: any
    length); item i is checked as ``number`` named "path[i]"."""
    if isinstance(value, np.ndarray) and value.ndim > 0:
        value = value.ravel().tolist()
    items = sequence(value, path, want) if counts is None else items_of(value, path, counts, want)
    return [number(v, f"{path}[{i}]") for i, v in enumerate(items)]


def integers(
    value: Any, path: str, want: str, counts: Sequence[int], low: int, high: Optional[int] = None
) -> List[int]:
    """The integers of a sequence of one of the lengths `counts`, each checked as ``integer``."""
    items = items_of(value, path, counts, want)
    return [integer(v, f"{path}[{i}]", low, high) for i, v in enumerate(items)]


def number_or_floats(value: Any, path: str, want: str) -> List[float]:
    """[value] for one number, else the numbers of a sequence (see ``floats``)."""
    if is_number(value):
        return [number(value, path)]
    return floats(value, path, want)


def real_array(value: Any, path: str) -> NDArray[Any]:
    """`value` as an array of real numbers (of a float, int, uint or bool dtype), not cast;
    TypeError naming `path` for an array of another dtype: complex (a cast to float would drop
    the imaginary part), object (None, mixed values), str or bytes."""
    array = np.asarray(value)
    if array.dtype.kind not in "fiub":
        raise TypeError(f"{path}: want numbers, got an array of {array.dtype}")
    return array


def float_array(value: Any, path: str, want: str) -> NDArray[np.float64]:
    """`value` as a float64 array of real numbers (see ``real_array``); TypeError naming `path` and
    `want` when it is no array at all (a str, None, a ragged sequence)."""
    if isinstance(value, (str, bytes, Mapping)) or value is None:
        raise TypeError(f"{path} = {shown(value)}: want {want}")
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"{path} = {shown(value)}: want {want}") from None
    return np.asarray(real_array(array, path), dtype=np.float64)


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


def dtype_value(dtype: Union[str, int, np.dtype[Any], type, None], path: str = "dtype") -> Any:
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


def bytes_per_value(dtype: int) -> Optional[int]:
    """The bytes of one value of a Field's dtype (4 for DTYPE_FLOAT32 or DTYPE_UNSPECIFIED, 2 for
    DTYPE_FLOAT16), or None for a dtype this client does not know."""
    known = _NUMPY_DTYPE.get(dtype)
    return None if known is None else known.itemsize


def field_to_array(field: common_pb2.Field, path: str = "field") -> NDArray[np.floating[Any]]:
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
    dtype: Union[str, int, np.dtype[Any], type, None] = None,
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
    real_array(array, path)
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
    field.data = _cast(array, _NUMPY_DTYPE[kind], path).tobytes()
    if spacing is not None:
        want = "a number or a sequence (sx, sy) or (sx, sy, sz)"
        given = np.atleast_1d(float_array(spacing, f"{path}.spacing", want))
        s = [float(given[0])] * 3 if given.size == 1 else [float(v) for v in given]
        field.spacing.CopyFrom(vec3(s, f"{path}.spacing"))
    if origin is not None:
        field.origin.CopyFrom(vec3(origin, f"{path}.origin"))
    return field


def _cast(
    array: NDArray[Any], dtype: np.dtype[np.floating[Any]], path: str
) -> NDArray[np.floating[Any]]:
    """`array` as a contiguous array of `dtype`; ValueError naming `path`, the first value and its
    index when a finite value is beyond the dtype's range (the cast would send it as inf)."""
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.ascontiguousarray(array, dtype=dtype)
    if array.dtype == dtype or array.dtype.kind == "b":
        return out
    overflow = np.isinf(out) & np.isfinite(array)
    if overflow.any():
        index = tuple(int(i) for i in np.argwhere(overflow)[0])
        value = array[index].item()
        limit = float(np.finfo(dtype).max)
        raise ValueError(
            f"{path}{list(index)} = {value!r}: beyond {dtype.name}, want |value| <= {limit:g}"
        )
    return out


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
    items = floats(value, path, "(x, y) or (x, y, z)", (2, 3))
    return common_pb2.Vec3(x=items[0], y=items[1], z=items[2] if len(items) == 3 else 0.0)


def points_to_vec3(points: ArrayLike, path: str = "points") -> Iterable[common_pb2.Vec3]:
    """Vec3 messages from an array of shape (n, 2) or (n, 3)."""
    array = float_array(points, path, "an array of shape (n, 2) or (n, 3)")
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
        x, y = floats(value, path, "(x, y)", (2,))
        return cls(x=x, y=y)
    if name == "squall.v1.SimTime" and not isinstance(value, (Mapping, Message)):
        return cls(seconds=number(value, path))
    return None


def is_repeated(fd: _descriptor.FieldDescriptor) -> bool:
    """Whether `fd` is a repeated field: `is_repeated` where protobuf has it (newer releases, which
    dropped `label`), else its label."""
    repeated = getattr(fd, "is_repeated", None)
    if repeated is not None:
        return bool(repeated)
    label: int = getattr(fd, "label")  # not in the type hints of newer releases
    return label == fd.LABEL_REPEATED


def _scalar(fd: _descriptor.FieldDescriptor, value: Any, path: str) -> Any:
    """`value` checked for a field of fd's type (see the module docstring)."""
    if fd.enum_type is not None:
        return enum_value(fd.enum_type, value, path)
    if fd.type == fd.TYPE_BYTES:
        return byte_string(value, path)
    if fd.type == fd.TYPE_STRING:
        if not isinstance(value, str):
            raise TypeError(f"{path} = {shown(value)}: want a string")
        return value
    if fd.type == fd.TYPE_BOOL:
        return flag(value, path)
    if fd.cpp_type == fd.CPPTYPE_DOUBLE:
        return number(value, path)
    if fd.cpp_type == fd.CPPTYPE_FLOAT:
        return float32(value, path)
    low, high = _INTEGER_RANGES[fd.cpp_type]
    return integer(value, path, low, high)


def set_fields(message: Message, values: Mapping[str, Any], path: str) -> None:
    """Sets the fields of `message` from a mapping (None values leave a field unset)."""
    # protobuf's Python Descriptor or upb's, which has the same members (typed apart).
    descriptor = cast(_descriptor.Descriptor, message.DESCRIPTOR)
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
        if is_repeated(fd):
            container = getattr(message, key)
            del container[:]
            if fd.message_type is not None:
                want = f"a sequence of {fd.message_type.name}"
                for i, item in enumerate(sequence(value, where, want)):
                    sub = container.add()
                    sub.CopyFrom(to_message(type(sub), item, f"{where}[{i}]"))
            else:
                if isinstance(value, np.ndarray) and value.ndim > 0:
                    value = value.ravel().tolist()
                items = sequence(value, where, "a sequence")
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


def repeated_per(
    values: Union[float, Sequence[float], None], count: int, path: str = "values"
) -> Optional[List[float]]:
    """A number repeated `count` times, a sequence of numbers as a list, None as None."""
    if values is None:
        return None
    items = number_or_floats(values, path, "a number or a sequence of numbers")
    return items * count if is_number(values) else items


def fields_dict(
    fields: Iterable[common_pb2.Field], path: str = "fields"
) -> Dict[str, NDArray[np.floating[Any]]]:
    """name -> array for Fields (see field_to_array)."""
    return {f.name: field_to_array(f, f"{path}.{f.name}") for f in fields}
