"""Fast HDF5 reads (identifier/io/hdf5_reads.py) give what h5py's high-level
reads give, for every kind of attribute and dataset a trace may hold."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from structbench.identifier.io import hdf5_reads
from structbench.identifier.io.hdf5_reads import attributes, decoded, samples
from structbench.identifier.io.traces import read_trace
from identify_synth import cantilever_trace

STRINGS = {"utf8": "m/s^2 é∂", "bytes": b"rms", "fixed": np.bytes_(b"abc"),
           "string-array": np.array(["a", "b"], dtype=h5py.string_dtype()),
           "string-1x1": np.array([["a"]], dtype=h5py.string_dtype())}
NUMBERS = {"int": 7, "int32": np.int32(-3), "uint8": np.uint8(200), "uint64": np.uint64(2**63 + 5),
           "int64-big": np.int64(2**62 + 1), "float": 0.02, "float32": np.float32(0.1), "float16": np.float16(0.3),
           "longdouble": np.longdouble(1.5), "nan": np.nan, "inf": -np.inf, "big-endian": np.array(2.5, dtype=">f8"),
           "big-endian-int": np.array(3, dtype=">i4"), "bool": True, "complex": 1 + 2j}
ARRAYS = {"location": np.array([6.0, 0.0, 0.0]), "ints": np.array([1, 2, 3]), "int32s": np.array([1, 2], np.int32),
          "float32s": np.array([1.5], np.float32), "one": np.array([7]), "bools": np.array([True, False]),
          "big-endian-array": np.array([1.0, 2.0], ">f8"), "empty-array": np.zeros(0), "matrix": np.ones((2, 2))}
ALL = STRINGS | NUMBERS | ARRAYS | {"empty": h5py.Empty("f8")}


def same(a, b) -> bool:
    if type(a) is not type(b) or getattr(a, "dtype", None) != getattr(b, "dtype", None):
        return False
    if isinstance(a, np.ndarray):
        return a.shape == b.shape and bool(np.all((a == b) | ((a != a) & (b != b))))
    return a == b or (a != a and b != b)


@pytest.fixture()
def attributed(tmp_path):
    path = tmp_path / "a.h5"
    with h5py.File(path, "w") as f:
        f.attrs.update(ALL)
        f.attrs.create("ascii", "hello", dtype=h5py.string_dtype("ascii"))
        f.attrs.create("bad-utf8", b"\xff\xfe", dtype=h5py.string_dtype("utf-8"))
        f.create_dataset("d", data=np.ones(3)).attrs.update(ALL)
    return path


def test_attributes_equal_h5py_for_every_type(attributed):
    with h5py.File(attributed) as f:
        for obj in (f, f["d"]):
            fast = attributes(obj.id)
            assert list(fast) == list(obj.attrs)
            wrong = {k: (fast[k], obj.attrs[k]) for k in obj.attrs if not same(fast[k], decoded(obj.attrs[k]))}
            assert not wrong
            assert fast["utf8"] == "m/s^2 é∂" and fast["int"] == 7 and type(fast["float32"]) is float


def test_common_types_skip_h5py_high_level(attributed, monkeypatch):
    """Scalar strings and numbers and arrays of native 8-byte numbers are read
    with the low-level calls alone (the speed of a folder read rests on it)."""
    monkeypatch.setattr(hdf5_reads, "high_level", lambda oid: pytest.fail("took the slow path"))
    common = ["utf8", "bytes", "int", "int32", "uint8", "int64-big", "float", "float32", "float16", "nan",
              "big-endian", "location", "ints", "one", "matrix", "empty-array"]
    with h5py.File(attributed) as f:
        got = attributes(f["d"].id, common + ["absent"])
    assert list(got) == common
    assert got["int64-big"] == 2**62 + 1 and got["float16"] == float(np.float16(0.3))
    assert got["location"].tolist() == [6.0, 0.0, 0.0] and got["location"].dtype == np.float64


@pytest.mark.parametrize("data", [np.arange(5, dtype=np.int16), np.linspace(0, 1, 5, dtype=np.float32),
                                  np.array([2**62 + 1, -3], dtype=np.int64), np.zeros(0)])
def test_samples_equal_numpy_conversion(tmp_path, data):
    with h5py.File(tmp_path / "s.h5", "w") as f:
        f["x"] = data
        got = samples(f["x"].id)
    assert got.dtype == np.float64 and np.array_equal(got, np.asarray(data, dtype=float))


@pytest.mark.parametrize("data", [np.array([b"x"] * 3), np.ones((3, 2)), np.ones(3, complex), np.ones(3, bool),
                                  np.float64(1.0)])
def test_samples_leave_other_datasets_to_h5py(tmp_path, data):
    with h5py.File(tmp_path / "s.h5", "w") as f:
        f["x"] = data
        assert samples(f["x"].id) is None


def test_a_trace_with_unusual_but_valid_types_reads_as_before(tmp_path):
    """float32 samples, int32 nodes, fixed-length unit strings and float32
    locations (h5py's path for the attributes) give the same channel."""
    path = cantilever_trace(tmp_path / "a.h5")
    ref = read_trace(path).channels["displacement_7_w"]
    with h5py.File(path, "a") as f:
        attrs = dict(f["channels/displacement_7_w"].attrs)
        del f["channels/displacement_7_w"]
        f["channels/displacement_7_w"] = ref.data.astype(np.float32)
        f["channels/displacement_7_w"].attrs.update(attrs | {
            "node": np.int32(7), "unit": np.bytes_(b"m"), "location": np.asarray(attrs["location"], np.float32)})
    odd = read_trace(path).channels["displacement_7_w"]
    assert (odd.node, odd.unit, odd.quantity, odd.direction, odd.noise_ratio, odd.noise_mode) == (
        7, "m", ref.quantity, ref.direction, ref.noise_ratio, ref.noise_mode)
    assert np.array_equal(odd.location, ref.location)
    assert np.array_equal(odd.data, ref.data.astype(np.float32).astype(float))
