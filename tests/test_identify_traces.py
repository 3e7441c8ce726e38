"""The trace reader: what it returns and how it complains."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from structbench.identifier.errors import IdentificationError
from structbench.identifier.io.traces import read_trace, read_traces
from identify_synth import cantilever_trace


@pytest.fixture()
def trace_path(tmp_path):
    return cantilever_trace(tmp_path / "traces" / "a.h5", {"displacement": 0.01})


def test_reads_channels_excitation_and_attributes(trace_path):
    trace = read_trace(trace_path)
    assert trace.dt == 0.05 and trace.step == 0.05 and trace.time.shape == (201,)
    assert trace.omega == 0.5 and trace.excitation_attrs["spec"] == []
    assert trace.structure == "ch4-cantilever-case1" and trace.test == "a" and trace.repetition == 0
    disp = trace.select("displacement")
    assert [c.name for c in disp] == ["displacement_2_theta", "displacement_7_w"]
    assert disp[1].unit == "m" and disp[0].unit == "rad" and disp[1].location == pytest.approx([6, 0, 0])
    assert disp[1].noise_ratio == 0.01 and disp[1].sigma()[0] == pytest.approx(
        0.01 * np.sqrt(np.mean(disp[1].data**2) / 1.0001))
    assert [c.name for c in trace.forces()] == ["force_7_w"]
    assert list(trace.excitation) == ["force_7_w"]


def test_campaign_folder_sorted_by_test_and_repetition(trace_path):
    for test, rep in (("b", 1), ("b", 0)):
        with h5py.File(trace_path) as src, h5py.File(trace_path.parent / f"{test}{rep}.h5", "w") as dst:
            for key in src:
                src.copy(key, dst)
            dst.attrs.update(dict(src.attrs) | {"test": test, "repetition": rep})
    traces = read_traces(trace_path.parent.parent)
    assert [(t.test, t.repetition) for t in traces] == [("a", 0), ("b", 0), ("b", 1)]


def test_missing_channel_is_named(trace_path):
    with pytest.raises(IdentificationError, match="missing channel velocity_7_w"):
        read_trace(trace_path).channel("velocity", 7, "w")


def test_missing_attribute_is_named(trace_path):
    with h5py.File(trace_path, "a") as f:
        del f["channels/displacement_7_w"].attrs["quantity"]
    with pytest.raises(IdentificationError, match="displacement_7_w has no attribute 'quantity'"):
        read_trace(trace_path)


def test_not_a_trace_file(tmp_path):
    with h5py.File(tmp_path / "x.h5", "w") as f:
        f.attrs["format"] = "something-else"
    with pytest.raises(IdentificationError, match="expected 'structbench-trace'"):
        read_trace(tmp_path / "x.h5")
    (tmp_path / "empty" / "traces").mkdir(parents=True)
    with pytest.raises(IdentificationError, match="no trace files"):
        read_traces(tmp_path / "empty")
    with pytest.raises(IdentificationError, match="no such trace file"):
        read_traces([tmp_path / "absent.h5"])


def test_harmonic_attribute_missing(trace_path):
    with h5py.File(trace_path, "a") as f:
        del f["excitation"].attrs["omega"]
    with pytest.raises(IdentificationError, match="no attribute 'omega'"):
        read_trace(trace_path).omega
