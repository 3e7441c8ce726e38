"""The trace reader refuses unusable samples (every identifier reads through
it): NaN or infinite samples, dead (constant) sensors, wrong dtypes, damaged
files; each error names the file and the channel, and ``identify`` exits 2."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from structbench.cli import main
from structbench.identifier.errors import IdentificationError
from structbench.identifier.io.traces import read_trace
from identify_synth import cantilever_trace

CHANNEL = "channels/displacement_7_w"


@pytest.fixture()
def trace_path(tmp_path):
    return cantilever_trace(tmp_path / "traces" / "a.h5")


def replace(path, name: str, data: np.ndarray) -> None:
    with h5py.File(path, "a") as f:
        attrs = dict(f[name].attrs)
        del f[name]
        f[name] = data
        f[name].attrs.update(attrs)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_samples_are_refused(trace_path, value):
    with h5py.File(trace_path, "a") as f:
        f[CHANNEL][17] = value
    with pytest.raises(IdentificationError) as err:
        read_trace(trace_path)
    assert f"a.h5: /{CHANNEL} is {value} at sample 17 (1 non-finite samples)" in str(err.value)


def test_a_constant_sensor_is_refused(trace_path):
    replace(trace_path, CHANNEL, np.full(201, 2.5e-3))
    with pytest.raises(IdentificationError, match=f"a.h5: /{CHANNEL} is constant \\(0.0025\\): a dead sensor"):
        read_trace(trace_path)


@pytest.mark.parametrize("data, shown", [(np.array([b"x"] * 201), "|S1"), (np.ones((201, 2)), "(201, 2)"),
                                         (np.ones(201, dtype=complex), "complex128")])
def test_wrong_dtypes_and_shapes_are_refused(trace_path, data, shown):
    replace(trace_path, CHANNEL, data)
    with pytest.raises(IdentificationError, match=f"a.h5: /{CHANNEL} is a dataset of .*{shown.replace('(', '.').replace(')', '.')}"):
        read_trace(trace_path)


def test_identify_exits_2_naming_the_channel(trace_path, tmp_path, capsys):
    with h5py.File(trace_path, "a") as f:
        f[CHANNEL][3] = np.nan
    code = main(["identify", str(tmp_path), "--method", "least-squares"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"/{CHANNEL} is nan at sample 3" in err
    assert not (tmp_path / "results").exists()


def test_a_truncated_file_is_refused(trace_path):
    data = trace_path.read_bytes()
    trace_path.write_bytes(data[:len(data) // 2])
    with pytest.raises(IdentificationError, match="cannot read trace file"):
        read_trace(trace_path)
