"""Spectral UFF 58 records in: FRFs (function type 4, complex), coherence
(6), auto (2) and cross (3) spectra become an FRF file
(``docs/frf-format.md``) under ``DIR/frf/``; from structbench's own FRF
export (written by pyuff), from pyuff directly (units g over lbf, a -Z
sensor) and from a hand-written ASCII record of the published layout."""
from __future__ import annotations


import numpy as np
import pytest
import pyuff

import structbench as sb
from structbench.identifier.io.frf_files import ChannelInfo, Frf, read_frf
from structbench.labdata.frf_export import write_frf_uff58

G, LBF = 9.80665, 4.4482216152605


def _frf() -> Frf:
    rng = np.random.default_rng(11)
    m, c = 64, 2
    f = np.arange(m) * 0.5
    h = rng.standard_normal((c, m)) + 1j * rng.standard_normal((c, m))
    nan = np.full((2, c, m), np.nan)
    return Frf(f, h, rng.uniform(0, 1, (c, m)), np.full((c, m), np.nan), nan, nan.copy(), np.full(m, 8),
               np.full(m, 8.0), np.ones(m), np.ones((c, m)), np.ones((c, m)) + 0j,
               ChannelInfo("force_1_w", "force", "N", 1, "w"),
               [ChannelInfo("acceleration_3_w", "acceleration", "m/s^2", 3, "w"),
                ChannelInfo("velocity_5_theta", "velocity", "rad/s", 5, "theta")],
               "H1", "welch", "hann", 256, 0.5, 0.95, 0.01, "density", {"campaign": "c", "group": "random"})


@pytest.mark.parametrize("binary", [True, False])
def test_structbench_frf_export_imports_back(tmp_path, binary):
    frf = _frf()
    source = write_frf_uff58(tmp_path / "random.uff", frf, binary)
    written = sb.import_data([source], tmp_path / "lab")
    assert [p.relative_to(tmp_path / "lab").as_posix() for p in written] == ["frf/random.h5"]
    back = read_frf(written[0])
    assert [r.name for r in back.responses] == ["acceleration_3_w", "velocity_5_theta"]
    assert back.force.name == "force_1_w" and back.estimator == "H1" and back.analysis == "imported"
    np.testing.assert_allclose(back.frequency, frf.frequency)
    np.testing.assert_allclose(back.frf, frf.frf, rtol=0 if binary else 1e-10, atol=0 if binary else 1e-11)
    np.testing.assert_allclose(back.coherence, frf.coherence, rtol=0 if binary else 1e-10)
    assert back.units == ["(m/s^2)/N", "(rad/s)/N"]


def test_pyuff_frf_in_g_per_lbf_with_spectra(tmp_path):
    """Units to SI (g/lbf -> (m/s^2)/N), a -Z response negated, auto and
    cross spectra placed by channel; time data in the same file go to a trace."""
    f = np.linspace(0.0, 50.0, 101)
    h = (1.0 + 2.0j) / (1.0 + 1j * f)
    common = dict(binary=1, rsp_node=4, ref_node=1, ref_dir=3, x=f, abscissa_spacing=1, abscissa_min=0.0,
                  abscissa_inc=0.5, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                  orddenom_spec_data_type=0)
    sets = [pyuff.prepare_58(func_type=4, id1="frf", rsp_dir=-3, data=h, ordinate_spec_data_type=12,
                             ordinate_axis_units_lab="g", orddenom_axis_units_lab="lbf",
                             **(common | {"orddenom_spec_data_type": 13})),
            pyuff.prepare_58(func_type=6, id1="coh", rsp_dir=-3, data=np.full(f.size, 0.9),
                             ordinate_spec_data_type=0, **common),
            pyuff.prepare_58(func_type=3, id1="cross", rsp_dir=-3, data=h * 2, ordinate_spec_data_type=12,
                             **common),
            pyuff.prepare_58(func_type=2, id1="auto a", rsp_dir=-3, data=np.full(f.size, 3.0),
                             ordinate_spec_data_type=12, **common),
            pyuff.prepare_58(func_type=2, id1="auto f", **(common | {"rsp_node": 1}), rsp_dir=3,
                             data=np.full(f.size, 5.0), ordinate_spec_data_type=13),
            pyuff.prepare_58(func_type=1, id1="acc", rsp_node=4, rsp_dir=3, ref_node=1, ref_dir=3, binary=1,
                             data=np.arange(10.0), x=np.arange(10) * 0.01, abscissa_spacing=1,
                             abscissa_spec_data_type=17, abscissa_axis_units_lab="s", ordinate_spec_data_type=12,
                             ordinate_axis_units_lab="m/s^2", orddenom_spec_data_type=0)]
    source = tmp_path / "lab.uff"
    pyuff.UFF(str(source)).write_sets(sets, "add")
    written = sb.import_data([source], tmp_path / "out")
    assert [p.name for p in written] == ["lab.h5", "lab.h5"] and written[1].parent.name == "frf"
    frf = read_frf(written[1])
    assert [r.name for r in frf.responses] == ["acceleration_4_z"] and frf.force.name == "force_1_z"
    np.testing.assert_allclose(frf.frf[0], -h * G / LBF, rtol=1e-12)
    np.testing.assert_allclose(frf.coherence[0], 0.9)
    np.testing.assert_allclose(frf.cross[0], -2 * h * G * LBF, rtol=1e-12)
    np.testing.assert_allclose(frf.auto_response[0], 3.0 * G**2)
    np.testing.assert_allclose(frf.auto_force, 5.0 * LBF**2)
    assert np.isnan(frf.random_error).all() and frf.attrs["source"] == "lab.uff"


def test_hand_written_complex_record(tmp_path):
    """Record 7 ordinate type 5 (complex single), even spacing in Hz; record
    12 ``6E13.5`` as real/imaginary pairs."""
    r6 = f"{4:5d}{0:10d}{0:5d}{0:10d} {'NONE':<10s}{2:10d}{3:4d} {'NONE':<10s}{1:10d}{3:4d}"
    r7 = f"{5:10d}{4:10d}{1:10d}{10.0:13.5E}{2.5:13.5E}{0.0:13.5E}"
    axis = "{:10d}{:5d}{:5d}{:5d} {:<20s} {:<20s}"
    lines = ["    -1", "    58", "H1 acceleration_2_w / force_1_w", "NONE", "NONE", "NONE", "NONE", r6, r7,
             axis.format(18, 0, 0, 0, "Frequency", "Hz"), axis.format(12, 0, 0, 0, "Acc", "m/s^2"),
             axis.format(13, 0, 0, 0, "Force", "N"), axis.format(0, 0, 0, 0, "NONE", "NONE"),
             "".join(f"{v:13.5E}" for v in (1.0, -1.0, 0.5, 0.25, -2.0, 0.0)),
             "".join(f"{v:13.5E}" for v in (0.0, 3.0)), "    -1"]
    source = tmp_path / "hand.unv"
    source.write_text("\n".join(lines) + "\n")
    frf = read_frf(sb.import_data([source], tmp_path / "lab")[0])
    np.testing.assert_allclose(frf.frequency, [10.0, 12.5, 15.0, 17.5])
    np.testing.assert_array_equal(frf.frf[0], [1 - 1j, 0.5 + 0.25j, -2.0, 3j])
    assert frf.responses[0].name == "acceleration_2_w" and np.isnan(frf.coherence).all()
