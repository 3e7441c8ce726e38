"""Virtual data out, lab data in: a campaign run through the harness, exported
to UFF 58 (binary, ASCII), CSV and SEP005, imported again with the exported
sensor map, and identified: the same results as on the original traces."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import pyuff
from sdypy_sep005.sep005 import assert_sep005

import structbench as sb
from e2e_fixtures import derive, run
from structbench.identifier.io.traces import read_traces

FORMATS = [("uff58", True), ("uff58", False), ("csv", True), ("sep005", True)]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """Chapter 3's harmonic test on the free-free beam, 2 s, two repetitions."""
    base = tmp_path_factory.mktemp("labdata")
    path = derive("ch3", base, {"harmonic": {"repetitions": 2, "duration": 2.0}})
    return run(path, base / "orig", fmu_dir=base / "fmus")


@pytest.fixture(scope="module")
def round_trips(campaign, tmp_path_factory) -> dict[tuple[str, bool], Path]:
    base = tmp_path_factory.mktemp("trips")
    out = {}
    for fmt, binary in FORMATS:
        exported = base / f"{fmt}-{binary}"
        files = sb.export_traces(campaign, fmt, exported, binary=binary)
        out[fmt, binary] = sb.import_data(files, base / f"in-{fmt}-{binary}", exported / "sensor-map.toml")[0].parents[1]
    return out


def _pairs(a: Path, b: Path):
    return list(zip(read_traces(a), read_traces(b), strict=True))


@pytest.mark.parametrize("fmt, binary", FORMATS)
def test_traces_come_back(campaign, round_trips, fmt, binary):
    exact = binary  # ASCII UFF: to the 13 printed digits
    for original, back in _pairs(campaign, round_trips[fmt, binary]):
        assert (back.test, back.repetition, back.attrs["group"], back.structure) == \
               (original.test, original.repetition, original.attrs["group"], original.structure)
        assert back.dt == original.dt and back.step == original.step and np.array_equal(back.time, original.time)
        assert list(back.channels) == list(original.channels) and list(back.excitation) == list(original.excitation)
        for name, c in [*original.channels.items(), *(("x/" + k, v) for k, v in original.excitation.items())]:
            d = back.channels[name] if not name.startswith("x/") else back.excitation[name[2:]]
            assert (d.quantity, d.unit, d.node, d.direction, d.noise_ratio, d.noise_mode) == \
                   (c.quantity, c.unit, c.node, c.direction, c.noise_ratio, c.noise_mode)
            np.testing.assert_array_equal(d.location, c.location)
            if exact:
                np.testing.assert_array_equal(d.data, c.data)
            else:
                np.testing.assert_allclose(d.data, c.data, rtol=5e-13, atol=5e-13 * np.abs(c.data).max())
        assert back.excitation_attrs == original.excitation_attrs
        assert back.noise_attrs == original.noise_attrs


def test_identifying_imported_data_gives_the_same_results(campaign, round_trips):
    original = sb.identify(campaign, "least-squares", samples=4)
    for (fmt, binary), folder in round_trips.items():
        again = sb.identify(folder, "least-squares", samples=4)
        assert len(again["runs"]) == len(original["runs"]) == 2
        for a, b in zip(original["runs"], again["runs"]):
            va = np.array([p["value"] for p in a["parameters"]])
            vb = np.array([p["value"] for p in b["parameters"]])
            tol = 1e-12 if binary else 1e-8
            np.testing.assert_allclose(vb, va, rtol=tol, err_msg=f"{fmt} binary={binary}")


def test_pyuff_reads_the_exported_uff(campaign, round_trips, tmp_path):
    files = sb.export_traces(campaign, "uff58", tmp_path / "b")
    files += sb.export_traces(campaign, "uff58", tmp_path / "a", binary=False)
    trace = read_traces(campaign)[0]
    for path in (files[0], files[2]):
        sets = pyuff.UFF(str(path)).read_sets()
        assert len(sets) == len(trace.channels) + len(trace.excitation)
        first = trace.channels[sets[0]["id1"].split("/", 1)[1]]
        np.testing.assert_allclose(sets[0]["data"], first.data, rtol=1e-11, atol=1e-11 * np.abs(first.data).max())
        assert sets[0]["rsp_node"] == first.node and sets[0]["ordinate_axis_units_lab"] == first.unit
        np.testing.assert_array_equal(sets[0]["x"], trace.time)


def test_sep005_export_passes_the_sep005_checker(campaign, tmp_path):
    for path in sb.export_traces(campaign, "sep005", tmp_path):
        channels = json.loads(path.read_text())
        assert_sep005(channels)
        assert {c["quantity"] for c in channels} == {"a", "v", "d", "f"}


def test_export_cli(campaign, tmp_path, capsys):
    from structbench.cli import main
    assert main(["export", str(campaign), "--format", "csv", "--out", str(tmp_path / "csv")]) == 0
    assert "2 csv file(s)" in capsys.readouterr().out
    header = (tmp_path / "csv" / "harmonic.r000.csv").read_text().splitlines()[0]
    assert header.startswith("time [s],channels/acceleration_1_w [m/s^2]")
