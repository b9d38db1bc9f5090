"""Values between the grader and a student's kernel, as data only (JSON), never as code or pickles.

Both ways: None, bool, int, float (nan and inf included), complex, str, bytes, bytearray, list, tuple, dict,
numpy arrays and scalars of numeric or boolean dtype, numpy record arrays (structured dtypes of those).
Grader to kernel also: the kit's own frozen dataclasses (e.g. `FurutaModel`), rebuilt in the kernel from
their fields. Kernel to grader, anything else arrives as an `Opaque` value that says what it was: a
student's object never runs code in the grader.
"""

from __future__ import annotations

import base64
import dataclasses
import hashlib
import importlib
import json
from typing import Any

import numpy as np

MAX_ELEMENTS = 1_000_000  # an array larger than this comes back as Opaque (a student's huge output)
MAX_DEPTH = 20
MAX_TEXT = 10_000
_KIT_PREFIX = "pendkit."


class WireError(ValueError):
    """A message that is not what this module writes."""


@dataclasses.dataclass(frozen=True)
class Opaque:
    """A value the kernel could not send as data: only its type and a short description came back."""

    type_name: str
    description: str

    def __repr__(self) -> str:
        return f"<{self.type_name}: {self.description}>"


def dumps(value: Any, allow_kit: bool = False) -> str:
    return json.dumps(encode(value, allow_kit), allow_nan=False)


def digest(value: Any) -> str:
    """A fingerprint of a value as sent (equal on both sides exactly when the value is unchanged)."""
    return hashlib.sha256(json.dumps(encode(value, allow_kit=True), allow_nan=False).encode()).hexdigest()


def loads(text: str, allow_kit: bool = False) -> Any:
    try:
        return decode(json.loads(text), allow_kit)
    except (ValueError, TypeError, KeyError, IndexError, AttributeError, RecursionError) as error:
        raise WireError(f"not a grading message: {error}") from None


def encode(value: Any, allow_kit: bool = False, depth: int = 0) -> Any:
    """A JSON-able description of `value` (see the module docstring for what is data)."""
    if depth > MAX_DEPTH:
        return {"opaque": ["nested", f"deeper than {MAX_DEPTH} levels"]}
    if value is None or isinstance(value, bool):
        return value
    if type(value) is float:  # the common cases first: tests send thousands of plain numbers
        return {"float": float.__repr__(value)}
    if type(value) is int and abs(value) < 10**4000:
        return {"int": int.__repr__(value)}
    if isinstance(value, (np.ndarray, np.generic)):  # before float: np.float64 is a float too
        return _encode_numpy(value)
    if isinstance(value, str):
        return {"str": str(value)[:MAX_TEXT]}
    if isinstance(value, (bytes, bytearray)):
        if len(value) > MAX_ELEMENTS:
            return {"opaque": [type(value).__name__, f"{len(value)} bytes, too many to send"]}
        key = "bytes" if isinstance(value, bytes) else "bytearray"
        return {key: base64.b64encode(bytes(value)).decode("ascii")}
    if isinstance(value, int):
        return {"int": int.__repr__(value)} if abs(value) < 10**4000 else {"opaque": ["int", "too large"]}
    if isinstance(value, float):
        return {"float": float.__repr__(value)}
    if isinstance(value, complex):
        return {"complex": [float.__repr__(value.real), float.__repr__(value.imag)]}
    if isinstance(value, (list, tuple)):
        key = "list" if isinstance(value, list) else "tuple"
        if len(value) > MAX_ELEMENTS:
            return {"opaque": [key, f"{len(value)} items, too many to send"]}
        return {key: [encode(item, allow_kit, depth + 1) for item in value]}
    if isinstance(value, dict):
        if len(value) > MAX_ELEMENTS:
            return {"opaque": ["dict", f"{len(value)} items, too many to send"]}
        return {"dict": [[encode(k, allow_kit, depth + 1), encode(v, allow_kit, depth + 1)] for k, v in value.items()]}
    kind = type(value)
    if allow_kit and dataclasses.is_dataclass(value) and kind.__module__.startswith(_KIT_PREFIX):
        fields = {f.name: encode(getattr(value, f.name), allow_kit, depth + 1) for f in dataclasses.fields(value)}
        return {"kit": [f"{kind.__module__}:{kind.__qualname__}", fields]}
    try:
        description = repr(value)[:200]
    except Exception:  # a student's __repr__ may raise
        description = "(no description)"
    return {"opaque": [getattr(kind, "__qualname__", "object"), description]}


def _encode_numpy(value) -> Any:
    array = np.asarray(value)
    if not _numeric(array.dtype):
        return {"opaque": [f"numpy {array.dtype}", f"shape {array.shape}"]}
    if array.size > MAX_ELEMENTS:
        return {"opaque": ["numpy.ndarray", f"{array.size} elements, too many to send"]}
    data = base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")
    key = "ndarray" if isinstance(value, np.ndarray) else "npscalar"
    dtype = array.dtype.descr if array.dtype.names else array.dtype.str
    return {key: [dtype, list(array.shape), data]}


def _numeric(dtype: np.dtype) -> bool:
    """Numbers or booleans, or records whose every field is (recursively): nothing that holds objects."""
    if dtype.names:
        return all(_numeric(dtype.fields[name][0]) for name in dtype.names)
    if dtype.subdtype is not None:
        return _numeric(dtype.subdtype[0])
    return dtype.kind in "biufc"


def _dtype_from_wire(described) -> np.dtype:
    if isinstance(described, str):
        dtype = np.dtype(described)
    else:  # a record's fields, as numpy's descr: [[name, type] or [name, type, shape], ...]
        dtype = np.dtype([(str(f[0]), _field_type(f[1])) + ((tuple(int(n) for n in f[2]),) if len(f) > 2 else ())
                          for f in described])
    if not _numeric(dtype):
        raise WireError(f"dtype {dtype} is not numeric")
    return dtype


def _field_type(described):
    return str(described) if isinstance(described, str) else _dtype_from_wire(described)


def decode(obj: Any, allow_kit: bool = False) -> Any:
    if obj is None or isinstance(obj, bool):
        return obj
    if not isinstance(obj, dict) or len(obj) != 1:
        raise WireError(f"unexpected {type(obj).__name__}")
    (key, body), = obj.items()
    if key == "str":
        return str(body)
    if key == "int":
        return int(body)
    if key == "float":
        return float(body)
    if key == "complex":
        return complex(float(body[0]), float(body[1]))
    if key in ("list", "tuple"):
        items = [decode(item, allow_kit) for item in body]
        return items if key == "list" else tuple(items)
    if key == "dict":
        return {_hashable(decode(k, allow_kit)): decode(v, allow_kit) for k, v in body}
    if key in ("bytes", "bytearray"):
        raw = base64.b64decode(str(body), validate=True)
        return raw if key == "bytes" else bytearray(raw)
    if key in ("ndarray", "npscalar"):
        described, shape, data = body
        dtype = _dtype_from_wire(described)
        array = np.frombuffer(base64.b64decode(data), dtype=dtype).reshape([int(n) for n in shape]).copy()
        return array if key == "ndarray" else array[()]
    if key == "opaque":
        return Opaque(str(body[0])[:100], str(body[1])[:200])
    if key == "kit" and allow_kit:
        return _rebuild_kit(body, allow_kit)
    raise WireError(f"unknown value kind {key!r}")


def _hashable(key):
    return tuple(key) if isinstance(key, list) else key


def _rebuild_kit(body, allow_kit: bool) -> Any:
    """Only the kit's own dataclasses, by module path: what the grader sent to the kernel."""
    path, fields = body
    module_name, _, name = str(path).partition(":")
    if not module_name.startswith(_KIT_PREFIX):
        raise WireError(f"{path} is not one of the kit's classes")
    kind = getattr(importlib.import_module(module_name), name)
    if not dataclasses.is_dataclass(kind):
        raise WireError(f"{path} is not a dataclass")
    return kind(**{k: decode(v, allow_kit) for k, v in fields.items()})
