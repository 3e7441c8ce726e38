"""FRFs (identifier/frf): against the closed-form FRF of 1-DOF and 2-DOF
systems simulated exactly (zero-order hold), against scipy's csd/welch,
the phase convention (the S_xf/S_ff mutation must fail), the noise bias of
H1/H2/Hv, the confidence bands' coverage, stepped-sine and impulse tests,
the file, UFF 58 and plot outputs, and the CLI/API on a campaign folder."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import pyuff
from scipy.signal import cont2discrete, csd, lfilter, ss2tf, welch
from scipy.signal import coherence as scipy_coherence

from structbench.identifier.errors import IdentificationError
from structbench.identifier.frf import estimate
from structbench.identifier.frf.plot import figure
from structbench.identifier.io.frf_files import read_frf, write_frf
from structbench.identifier.io.traces import Channel, Trace
from structbench.labdata.frf_export import write_frf_uff58

DT = 0.01  # s
SDOF = (np.array([[1.0]]), np.array([[2 * 0.02 * 2 * np.pi * 5.0]]), np.array([[(2 * np.pi * 5.0) ** 2]]))
TWO_DOF = (np.diag([1.0, 2.0]), 0.004 * np.array([[150.0, -50.0], [-50.0, 50.0]]) + 0.2 * np.diag([1.0, 2.0]),
           np.array([[150.0, -50.0], [-50.0, 50.0]]))


# --- exact simulation and the closed form -------------------------------------------------------------

def discrete(M, C, K, dt=DT):
    """ZOH matrices (Ad, Bd, Cd) of ``M x'' + C x' + K x = e_0 f``, output the displacements."""
    n = M.shape[0]
    minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ K, -minv @ C]])
    B = np.vstack([np.zeros((n, 1)), minv[:, [0]]])
    ad, bd, cd, _, _ = cont2discrete((A, B, np.hstack([np.eye(n), np.zeros((n, n))]), np.zeros((n, 1))), dt, "zoh")
    return ad, bd, cd


def simulate(system, force: np.ndarray) -> np.ndarray:
    """Displacements (n_dof, N) for the force at DOF 0 held over each sample (exact)."""
    ad, bd, cd = discrete(*system)
    out = []
    for i in range(cd.shape[0]):
        b, a = ss2tf(ad, bd, cd[[i]], np.zeros((1, 1)))
        out.append(lfilter(b[0], a, force))
    return np.array(out)


def closed_form(system, frequency: np.ndarray) -> np.ndarray:
    """``(K - omega^2 M + i omega C)^-1`` column 0, (n_dof, m), times the hold
    ``sinc(omega dt / 2) exp(-i omega dt / 2)`` of the force held over dt."""
    M, C, K = system
    w = 2 * np.pi * frequency
    h = np.linalg.inv(K[None] - w[:, None, None] ** 2 * M[None] + 1j * w[:, None, None] * C[None])[:, :, 0].T
    return h * np.sinc(frequency * DT) * np.exp(-1j * np.pi * frequency * DT)


def exact_discrete(system, frequency: np.ndarray) -> np.ndarray:
    """The sampled system's FRF ``Cd (e^(i omega dt) I - Ad)^-1 Bd`` (n_dof, m)."""
    ad, bd, cd = discrete(*system)
    z = np.exp(2j * np.pi * frequency * DT)
    return np.stack([cd @ np.linalg.solve(zz * np.eye(ad.shape[0]) - ad, bd) for zz in z])[:, :, 0].T


def channel(name: str, data: np.ndarray, quantity: str, node: int, unit: str) -> Channel:
    return Channel(name=name, data=data, quantity=quantity, unit=unit, node=node, direction="w",
                   location=np.full(3, np.nan))


def trace(force: np.ndarray, responses: np.ndarray, kind: str = "random", name: str = "t.h5",
          time: np.ndarray | None = None, **excitation) -> Trace:
    chans = {"force_1_w": channel("force_1_w", force, "force", 1, "N")}
    for i, x in enumerate(responses):
        chans[f"displacement_{i + 1}_w"] = channel(f"displacement_{i + 1}_w", x, "displacement", i + 1, "m")
    time = np.arange(force.size) * DT if time is None else time
    return Trace(path=Path(name), time=time, dt=DT, step=DT, channels=chans, excitation={},
                 attrs={"test": Path(name).stem, "group": "g", "campaign": "synthetic"},
                 excitation_attrs={"kind": kind, **excitation})


@pytest.fixture(scope="module")
def random_tests():
    """Noise-free white-force records of the 1-DOF and 2-DOF systems."""
    rng = np.random.default_rng(7)
    force = rng.standard_normal(2**17)
    return {name: (system, force, simulate(system, force)) for name, system in (("1dof", SDOF), ("2dof", TWO_DOF))}


def log_errors(estimated: np.ndarray, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative magnitude error ``|H^| / |H| - 1`` and phase error (deg)."""
    ratio = estimated / true
    return np.abs(ratio) - 1.0, np.degrees(np.angle(ratio))


# --- the estimates against the closed form ----------------------------------------------------------

@pytest.mark.parametrize("estimator", ["H1", "H2", "Hv"])
@pytest.mark.parametrize("name", ["1dof", "2dof"])
def test_estimates_match_the_closed_form_frf(random_tests, name, estimator):
    system, force, x = random_tests[name]
    frf = estimate([trace(force, x)], estimator, segment=2**13 * DT)
    true = closed_form(system, frf.frequency)
    band = (frf.frequency > 0.3) & (frf.frequency < 8.0)  # well below Nyquist (50 Hz): the hold is sinc x delay
    good = band & (frf.coherence >= 0.99)
    mag, phase = log_errors(frf.frf, true)
    assert good.sum() > 0.5 * band.sum() * len(x)
    assert np.median(np.abs(mag[good])) < 2e-3 and np.median(np.abs(phase[good])) < 0.1
    # within the stated random error (plus H2's bias 1 / gamma^2 - 1, H2 = H1 / gamma^2: the
    # response within a segment owes part of itself to earlier force, noise to the estimate)
    useful = band & (frf.coherence > 0.5)
    bias = (1 / frf.coherence - 1) if estimator != "H1" else 0 * frf.coherence
    assert np.all(np.abs(mag[useful]) <= 4 * frf.random_error[useful] + bias[useful] + 2e-3)
    assert np.all(np.abs(np.radians(phase[useful])) <= 4 * frf.random_error[useful] + 2e-3)
    # the sampled system's exact FRF agrees with closed form x hold in this band
    m, p = log_errors(exact_discrete(system, frf.frequency[band]), true[:, band])
    assert np.max(np.abs(m)) < 2e-3 and np.max(np.abs(p)) < 0.05
    assert frf.units == ["m/N"] * len(x) and frf.estimator == estimator and frf.analysis == "welch"


def test_phase_convention_catches_the_conjugated_h1(random_tests):
    """A peer library shipped H1 = S_xf / S_ff: the phase flips sign, and
    the closed-form check must fail for it."""
    system, force, x = random_tests["1dof"]
    frf = estimate([trace(force, x)], "H1", segment=2**13 * DT)
    true = closed_form(system, frf.frequency)
    good = (frf.frequency > 0.3) & (frf.frequency < 8.0) & (frf.coherence[0] >= 0.99)
    mutated = np.conj(frf.cross) / frf.auto_force  # S_xf / S_ff
    assert np.max(np.abs(log_errors(frf.frf[0, good], true[0, good])[1])) < 1.0
    assert np.max(np.abs(log_errors(mutated[0, good], true[0, good])[1])) > 30.0
    # below resonance a displacement lags the force: phase in (-90, 0) degrees
    low = (frf.frequency > 0.5) & (frf.frequency < 4.0)
    assert np.all((np.angle(frf.frf[0, low]) < 0) & (np.angle(frf.frf[0, low]) > -np.pi / 2))


def test_h1_and_coherence_equal_scipy_csd_and_welch(random_tests):
    _, force, x = random_tests["2dof"]
    n = 2**12
    frf = estimate([trace(force, x)], "H1", segment=n * DT, overlap=0.5, window="hann")
    _, s_ff = welch(force, fs=1 / DT, window="hann", nperseg=n, noverlap=n // 2)
    _, s_fx = csd(force, x, fs=1 / DT, window="hann", nperseg=n, noverlap=n // 2)  # conj(F) X
    _, gamma2 = scipy_coherence(force, x, fs=1 / DT, window="hann", nperseg=n, noverlap=n // 2)
    sel = slice(1, None)
    np.testing.assert_allclose(frf.frf[:, sel], (s_fx / s_ff)[:, sel], rtol=1e-9)
    np.testing.assert_allclose(frf.coherence[:, sel], gamma2[:, sel], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(frf.auto_force[sel], s_ff[sel], rtol=1e-9)
    assert frf.n_averages[0] == 2 * force.size // n - 1


# --- noise: bias and bands ---------------------------------------------------------------------------

@pytest.mark.parametrize("noisy", ["force", "response"])
def test_h1_is_biased_by_input_noise_h2_by_output_noise(random_tests, noisy):
    system, force, x = random_tests["1dof"]
    rng = np.random.default_rng(3)
    measured_force = force + (0.3 * np.std(force) * rng.standard_normal(force.size) if noisy == "force" else 0)
    measured_x = x + (0.3 * np.std(x) * rng.standard_normal(x.shape) if noisy == "response" else 0)
    t = trace(measured_force, measured_x)
    est = {e: estimate([t], e, segment=2**11 * DT) for e in ("H1", "H2", "Hv")}
    f = est["H1"].frequency
    sel = (f > 0.5) & (f < 8.0)
    true = np.abs(closed_form(system, f))[0, sel]
    ratio = {e: np.median(np.abs(r.frf[0, sel]) / true) for e, r in est.items()}
    if noisy == "force":  # |H1| = |H| / (1 + 0.09); H2 unbiased
        assert ratio["H1"] == pytest.approx(1 / 1.09, abs=0.01) and ratio["H2"] == pytest.approx(1.0, abs=0.01)
    else:  # H1 unbiased; H2 high where the response noise matters
        assert ratio["H1"] == pytest.approx(1.0, abs=0.01) and ratio["H2"] > 1.05
    mags = {e: np.abs(r.frf[0, sel]) for e, r in est.items()}
    assert np.all(mags["H1"] <= mags["Hv"] * (1 + 1e-12)) and np.all(mags["Hv"] <= mags["H2"] * (1 + 1e-12))


def test_confidence_bands_cover_the_true_frf_in_the_nominal_share():
    """200 realisations with output noise: the 95 % bands of |H1| and its
    phase each cover the true FRF in about 95 % of the cases (on lines where
    the random error is small enough for the Bendat & Piersol formulas)."""
    system = (SDOF[0], SDOF[1] * 2.5, SDOF[2])  # 5 % damping: 5 lines per half-power bandwidth below
    n_real, L, per = 200, 1024, 16 * 1024
    rng = np.random.default_rng(11)
    forces = rng.standard_normal((n_real, per))
    responses = simulate(system, forces.reshape(-1))[0].reshape(n_real, per)
    responses += 0.5 * np.std(responses) * rng.standard_normal(responses.shape)
    mag_in, phase_in, small = [], [], []
    true = exact_discrete(system, np.fft.rfftfreq(L, DT))[0]
    for r in range(n_real):
        frf = estimate([trace(forces[r], responses[r][None])], "H1", segment=L * DT, confidence=0.95)
        lo, hi = frf.magnitude_band[:, 0]
        mag_in.append((np.abs(true) >= lo) & (np.abs(true) <= hi))
        half = (frf.phase_band[1, 0] - frf.phase_band[0, 0]) / 2
        phase_in.append(np.abs(np.angle(true / frf.frf[0])) <= half)
        small.append(frf.random_error[0] < 0.1)
    mag_in, phase_in, small = map(np.array, (mag_in, phase_in, small))
    band = (frf.frequency > 0.5) & (frf.frequency < 45)
    keep = small & band
    assert keep.sum() > 1000
    assert 0.9 <= mag_in[keep].mean() <= 0.99
    assert 0.9 <= phase_in[keep].mean() <= 0.99


def test_overlap_factor_matches_the_hann_closed_form_and_the_direct_sum():
    """Welch's variance factor ``1 + 2 sum_j (1 - j/K) rho(j hop)``: for a
    periodic Hann window at 50 % overlap ``sum_n w_n w_(n+L/2) / sum_n w_n^2
    = 1/6`` exactly, so the factor is ``1 + 2 (1 - 1/K) / 36``; any window and
    hop against the direct O(L^2) sum (np.correlate)."""
    from scipy.signal import get_window

    from structbench.identifier.frf.spectra import overlap_correlation

    for L in (8, 1024, 16384):
        assert overlap_correlation(get_window("hann", L), L // 2, 10) == pytest.approx(1 + 2 * 0.9 / 36, rel=1e-12)
    w = np.random.default_rng(5).uniform(0.0, 1.0, 257)
    for hop, K in ((1, 400), (37, 20), (128, 3), (300, 5)):
        lags = np.arange(1, K) * hop
        lags = lags[lags < w.size]
        rho = (np.correlate(w, w, mode="full")[w.size - 1:][lags] / (w @ w)) ** 2
        direct = 1 + 2 * np.sum((1 - np.arange(1, lags.size + 1) / K) * rho)
        assert overlap_correlation(w, hop, K) == pytest.approx(direct, rel=1e-12)


# --- stepped sine and impulse --------------------------------------------------------------------------

def test_stepped_sine_lines_match_the_sampled_system():
    omegas = [2 * np.pi * f for f in (1.0, 4.5, 5.0, 12.0)]
    time = np.arange(6000) * DT
    traces = []
    for i, w in enumerate(omegas):
        force = 2.0 * np.cos(w * time)
        x = simulate(SDOF, force)
        traces.append(trace(force, x, "harmonic", f"sine-{i + 1:02d}.h5", time, omega=w, window_start=30.0))
    frf = estimate(traces[::-1], "H1")
    np.testing.assert_allclose(frf.omega, omegas)
    true = exact_discrete(SDOF, frf.frequency)
    mag, phase = log_errors(frf.frf, true)
    assert np.max(np.abs(mag)) < 1e-6 and np.max(np.abs(phase)) < 1e-4
    assert frf.analysis == "harmonic" and np.all(frf.n_averages == 8) and np.all(frf.coherence > 0.999999)


def test_impulse_frf_and_leakage_warning():
    n = 4096  # 41 s: the 1-DOF response (decay time 1.6 s) dies out
    force = np.zeros(n)
    force[10] = 1.0 / DT
    x = simulate(SDOF, force)
    frf = estimate([trace(force, x, "impulse")], "H1")
    true = exact_discrete(SDOF, frf.frequency)
    mag, phase = log_errors(frf.frf[:, 1:], true[:, 1:])
    assert np.max(np.abs(mag)) < 1e-6 and np.max(np.abs(phase)) < 1e-4
    assert frf.window == "boxcar" and not frf.warnings[:-1]
    short = estimate([trace(force[:200], x[:, :200], "impulse")], "H1")
    assert any("has not decayed" in w and "displacement_1_w" in w for w in short.warnings)


def test_errors_name_the_file_and_channel(random_tests):
    _, force, x = random_tests["1dof"]
    with pytest.raises(IdentificationError, match="t.h5: no channel 'velocity_3_w'"):
        estimate([trace(force, x)], responses=["velocity_3_w"])
    with pytest.raises(IdentificationError, match="estimator"):
        estimate([trace(force, x)], "H3")
    with pytest.raises(IdentificationError, match="segment"):
        estimate([trace(force[:100], x[:, :100])], segment=10.0)


# --- files, UFF 58, plot -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def two_dof_frf(random_tests):
    _, force, x = random_tests["2dof"]
    return estimate([trace(force, x)], "Hv", segment=2**10 * DT)


def test_frf_file_round_trip_and_damage(two_dof_frf, tmp_path):
    path = write_frf(tmp_path / "g.h5", two_dof_frf)
    back = read_frf(path)
    for name in ("frequency", "frf", "coherence", "random_error", "magnitude_band", "phase_band", "n_averages",
                 "n_effective", "auto_force", "auto_response", "cross"):
        np.testing.assert_array_equal(getattr(back, name), getattr(two_dof_frf, name), err_msg=name)
    assert back.responses == two_dof_frf.responses and back.force == two_dof_frf.force
    for name in ("estimator", "analysis", "window", "segment", "overlap", "confidence", "dt", "spectra_scaling"):
        assert getattr(back, name) == getattr(two_dof_frf, name), name
    assert back.attrs["traces"] == ["t.h5"] and back.units == ["m/N", "m/N"]
    import h5py
    with h5py.File(path, "a") as f:
        del f["coherence"]
        f["coherence"] = np.zeros(3)
    with pytest.raises(IdentificationError, match=r"g.h5: /coherence is float64 \(3,\), expected \(2, 513\)"):
        read_frf(path)


@pytest.mark.parametrize("binary", [True, False])
def test_uff58_type4_round_trip_through_pyuff(two_dof_frf, tmp_path, binary):
    path = write_frf_uff58(tmp_path / "g.uff", two_dof_frf, binary=binary, source="g.h5")
    sets = pyuff.UFF(str(path)).read_sets()
    assert [s["func_type"] for s in sets] == [4, 6, 4, 6]
    tol = 0 if binary else 1e-11
    for i, r in enumerate(two_dof_frf.responses):
        frf, coh = sets[2 * i], sets[2 * i + 1]
        assert (frf["rsp_node"], frf["rsp_dir"], frf["ref_node"], frf["ref_dir"]) == (r.node, 3, 1, 3)
        assert frf["ordinate_spec_data_type"] == 8 and frf["orddenom_spec_data_type"] == 13
        assert frf["abscissa_spec_data_type"] == 18 and frf["id1"].startswith(f"Hv {r.name} / force_1_w")
        np.testing.assert_allclose(frf["x"], two_dof_frf.frequency, rtol=1e-12 if binary else 1e-5)  # ASCII: E13.5
        np.testing.assert_allclose(frf["data"], two_dof_frf.frf[i], rtol=tol, atol=0)
        np.testing.assert_allclose(coh["data"], two_dof_frf.coherence[i], rtol=tol, atol=1e-300)


def test_plot_has_magnitude_phase_and_coherence_axes_with_the_frf_data(two_dof_frf, tmp_path):
    import matplotlib
    backend = matplotlib.get_backend()
    fig = figure(two_dof_frf)
    mag, phase, coh = fig.axes
    assert len(fig.axes) == 3 and matplotlib.get_backend() == backend
    for i in range(2):
        np.testing.assert_array_equal(mag.lines[i].get_xdata(), two_dof_frf.frequency)
        np.testing.assert_array_equal(mag.lines[i].get_ydata(), np.abs(two_dof_frf.frf[i]))
        np.testing.assert_array_equal(phase.lines[i].get_ydata(), np.degrees(np.angle(two_dof_frf.frf[i])))
        np.testing.assert_array_equal(coh.lines[i].get_ydata(), two_dof_frf.coherence[i])
    assert mag.get_yscale() == "log" and "coherence" in coh.get_ylabel() and "deg" in phase.get_ylabel()


# --- CLI and API on a campaign folder ------------------------------------------------------------------

FRAME = Path(__file__).resolve().parents[1] / "docs" / "examples" / "shear-frame-3.toml"
CAMPAIGN = f'''
name = "frf-frame"
structure = "{FRAME}"
seed = 5

[[tests]]
name = "random"
dt = 0.01
duration = 160.0
noise = {{sensor = {{acceleration = 0.01, force = 0.01}}, mode = "rms"}}
excitation = [{{kind = "random", node = 3, dir = "x", rms = 1000.0, band = [0.0, 300.0]}}]
sensors = [{{nodes = "all", quantities = ["acceleration"]}}, {{nodes = [3], quantities = ["force"]}}]

[[tests]]
name = "sine"
dt = 0.01
sensors = [{{nodes = "all", quantities = ["displacement"]}}]

[[tests.excitation]]
kind = "stepped-sine"
node = 3
dir = "x"
amplitude = 1000.0
omegas = [10.0, 30.0]
ramp = 2.0
settle = 10.0
window = 8.0

[[tests]]
name = "free"
dt = 0.01
duration = 2.0
excitation = [{{kind = "initial", node = 3, dir = "x", displacement = 0.01}}]
sensors = [{{nodes = "all", quantities = ["displacement"]}}]
'''


@pytest.fixture(scope="module")
def frame_folder(tmp_path_factory) -> Path:
    from e2e_fixtures import run
    base = tmp_path_factory.mktemp("frf-campaign")
    (base / "frf.toml").write_text(CAMPAIGN)
    return run(base / "frf.toml", base / "out", fmu_dir=base / "fmus")


def model_frf(dt: float, frequency: np.ndarray, quantity: str) -> np.ndarray:
    """The shear frame's sampled-data FRF per force at node 3 (3, m): ZOH of the model."""
    from structbench.models import load_model
    ss = load_model(str(FRAME)).state_space()
    ad, bd = ss.discretize(dt)
    out, feed = {"acceleration": (ss.Ca, ss.Da), "displacement": (ss.Cd, 0 * ss.Da)}[quantity]
    z = np.exp(2j * np.pi * frequency * dt)
    h = np.stack([out @ np.linalg.solve(zz * np.eye(ad.shape[0]) - ad, bd) + feed for zz in z])
    return h[:, :, 2].T


def test_cli_and_api_write_frfs_that_match_the_model(frame_folder, tmp_path, capsys):
    import structbench as sb
    from structbench.cli import main

    assert main(["frf", str(frame_folder), "--estimator", "H1", "--segment", "20.48"]) == 0
    printed = capsys.readouterr().out
    assert "random: H1 of 3 response(s) per force_3_x, welch" in printed and "free: skipped" in printed
    random = read_frf(frame_folder / "frf" / "random.h5")
    assert (frame_folder / "frf" / "random.png").stat().st_size > 10_000
    assert [r.name for r in random.responses] == ["acceleration_1_x", "acceleration_2_x", "acceleration_3_x"]
    assert random.units == ["(m/s^2)/N"] * 3 and random.segment == 2048
    line = random.frequency > 0.0  # the model's accelerance is 0 at 0 Hz
    good = ((random.coherence >= 0.99) & (random.frequency > 1.0) & (random.frequency < 40.0))[..., line]
    mag, phase = log_errors(random.frf[..., line], model_frf(0.01, random.frequency[line], "acceleration"))
    assert good.sum() > 500 and np.median(np.abs(mag[good])) < 0.01 and np.median(np.abs(phase[good])) < 1.0

    done = sb.frf(frame_folder, "H2", groups=["sine"], plot=False)
    sine = done.frfs["sine"]
    assert list(done.files) == ["sine"] and not done.plots and sine.analysis == "harmonic"
    np.testing.assert_allclose(sine.omega, [10.0, 30.0])
    assert sine.force.name == "force_3_x" and sine.units == ["m/N"] * 3  # the commanded force (no load cell)
    mag, phase = log_errors(sine.frf, model_frf(0.01, sine.frequency, "displacement"))
    assert np.max(np.abs(mag)) < 0.01 and np.max(np.abs(phase)) < 1.0

    assert main(["frf", str(frame_folder), "--group", "random", "--estimator", "Hv", "--no-plot", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert listed["files"] == {"random": str(frame_folder / "frf" / "random.h5")} and listed["plots"] == {}
    assert read_frf(frame_folder / "frf" / "random.h5").estimator == "Hv"
    assert main(["frf", str(frame_folder), "--segment", "20.48"]) == 0  # back to H1 for the export below
    capsys.readouterr()

    with pytest.raises(IdentificationError, match="no force"):
        sb.frf(frame_folder, groups=["free"])
    assert main(["frf", str(frame_folder), "--group", "nothing"]) == 2
    assert "no test group 'nothing'" in capsys.readouterr().err

    files = sb.export_traces(frame_folder, "uff58", tmp_path / "lab")
    frf_sets = pyuff.UFF(str(tmp_path / "lab" / "frf" / "random.uff")).read_sets()
    assert tmp_path / "lab" / "frf" / "sine.uff" in files and [s["func_type"] for s in frf_sets] == [4, 6] * 3
    np.testing.assert_allclose(frf_sets[4]["data"], random.frf[2], rtol=0, atol=0)
