"""HDF5 attributes and 1-D datasets read with few library calls.

h5py's high-level ``obj.attrs[name]`` costs some 15 calls into the library
per attribute, and a trace of 100 channels holds some 700 attributes. Here
the common types are read with h5py's low-level API (open, type, shape,
read): scalar variable-length strings, scalar integers
of at most 8 bytes (unsigned: fewer), scalar floats of at most 8 bytes, and
arrays of native 8-byte integers or floats. Every other attribute goes
through h5py's ``AttributeManager``. Either way the value is what
``attrs[name]`` gives, with bytes decoded (UTF-8) and numpy scalars as
Python numbers.
"""
from __future__ import annotations

import sys
from collections.abc import Iterable
from typing import Any

import h5py
import numpy as np
from h5py import h5a, h5d, h5o, h5s, h5t

_VLEN_STR = h5py.string_dtype("utf-8")
_VLEN_STR_TYPE = h5t.py_create(_VLEN_STR)
_NATIVE = h5t.ORDER_LE if sys.byteorder == "little" else h5t.ORDER_BE


def decoded(value: Any) -> Any:
    """``bytes`` as ``str`` (UTF-8, bad bytes replaced), numpy scalars as Python numbers."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.generic):
        return value.item()
    return value


def high_level(oid: h5o.ObjectID) -> h5py.HLObject:
    """The h5py high-level object (dataset, group or file) of a low-level identifier."""
    if isinstance(oid, h5d.DatasetID):
        return h5py.Dataset(oid)
    return h5py.File(oid) if isinstance(oid, h5py.h5f.FileID) else h5py.Group(oid)


def _fast(attr: h5a.AttrID) -> tuple[bool, Any]:
    """(True, value) for the common types, (False, None) for the others."""
    tid, shape = attr.get_type(), attr.shape
    kind = type(tid)
    if shape is None:  # empty dataspace
        return False, None
    if kind is h5t.TypeStringID:
        if not tid.is_variable_str() or shape != ():
            return False, None
        value = np.empty((), dtype=_VLEN_STR)
        attr.read(value, mtype=_VLEN_STR_TYPE)  # a conversion h5py cannot do raises: the general path then
        text = value[()]
        return True, text.decode("utf-8", "surrogateescape") if isinstance(text, bytes) else text
    if kind not in (h5t.TypeIntegerID, h5t.TypeFloatID):
        return False, None
    size, integer = tid.get_size(), kind is h5t.TypeIntegerID
    if shape != ():  # arrays keep their dtype: only native 8-byte numbers here
        if size != 8 or tid.get_order() != _NATIVE or (integer and tid.get_sign() != h5t.SGN_2):
            return False, None
    elif size > 8 or (integer and size == 8 and tid.get_sign() != h5t.SGN_2):
        return False, None
    value = np.empty(shape, dtype=np.int64 if integer else np.float64)
    attr.read(value, mtype=h5t.NATIVE_INT64 if integer else h5t.NATIVE_DOUBLE)
    return True, value.item() if shape == () else value


def attributes(oid: h5o.ObjectID, names: Iterable[str] | None = None) -> dict[str, Any]:
    """The attributes of an HDF5 object, all (in h5py's order) or those of
    ``names`` that it has, decoded (:func:`decoded`)."""
    if names is None:
        present = list(high_level(oid).attrs)
    else:
        found: set[str] = set()
        h5a.iterate(oid, lambda name: found.add(name.decode("utf-8", "surrogateescape")))
        present = [n for n in names if n in found]
    out: dict[str, Any] = {}
    slow = None
    for name in present:
        try:
            done, value = _fast(h5a.open(oid, name.encode("utf-8", "surrogateescape")))
        except (TypeError, ValueError, OSError):  # a conversion the library refuses
            done, value = False, None
        if not done:
            slow = slow if slow is not None else high_level(oid).attrs
            value = slow[name]
        out[name] = decoded(value)
    return out


def samples(dsid: h5d.DatasetID) -> np.ndarray | None:
    """A 1-D dataset of integers or floats as float64 (n,); None for any
    other dataset (string, complex, enumerated, n-D, empty dataspace)."""
    if type(dsid.get_type()) not in (h5t.TypeIntegerID, h5t.TypeFloatID) or len(dsid.shape or ()) != 1:
        return None
    data = np.empty(dsid.shape, dtype=np.float64)
    if data.size:
        dsid.read(h5s.ALL, h5s.ALL, data, mtype=h5t.NATIVE_DOUBLE)
    return data
