"""The modal method on one displacement sensor of a 1-DOF oscillator under a
random force (issue 22): a static offset of the sensor (the exported FMU's
``y0``) is no mode. Exact zero-order-hold simulation (tests/identify_synth.py),
closed-form omega = sqrt(k / m), zeta = c / (2 sqrt(k m))."""
from __future__ import annotations

import numpy as np
import pytest

from identify_synth import memory_trace, oscillator, respond
from structbench.identifier.modal import identify

M, C, K = 1.0, 10.0, 1.0e4  # kg, N s/m, N/m: omega 100 rad/s, zeta 0.05
OMEGA, ZETA = np.sqrt(K / M), C / (2.0 * np.sqrt(K * M))


def one_sensor(offset: float, seed: int = 0, seconds: float = 60.0, dt: float = 1e-3):
    """The oscillator's displacement under a white force (1 N RMS, numpy
    seed ``seed``) plus ``offset`` m, with white noise of 2 % of the
    offset-free response's RMS (seed ``seed + 1000``): the same noise
    whatever the offset."""
    model = oscillator(M, C, K)
    force = np.random.default_rng(seed).standard_normal((int(seconds / dt), 1))
    response = respond(model, force, dt)
    noisy = memory_trace(model, response, dt, [("displacement", 1, "x")], noise={"displacement": 0.02},
                         seed=seed + 1000)
    noisy.channels["displacement_1_x"].data[:] += offset
    return noisy


def near(result) -> tuple[float, float]:
    """omega rad/s and zeta of the reported mode nearest OMEGA."""
    j = int(np.argmin(np.abs(np.asarray(result.omega) - OMEGA)))
    return result.omega[j], result.damping[j]


def test_a_static_offset_of_the_single_sensor_changes_nothing():
    # a 1 mm offset, 14 times the response's RMS (72 um): without the mean
    # removed it fills every lagged covariance (seed 0: 2400 block rows
    # against 255, zeta -25 % against +0.9 % without the offset)
    plain = identify([one_sensor(0.0)], uncertainty="off")
    offset = identify([one_sensor(1e-3)], uncertainty="off")
    assert offset.details["block_rows"] == plain.details["block_rows"]
    (w0, z0), (w1, z1) = near(plain), near(offset)
    assert abs(w1 / w0 - 1) < 1e-6 and abs(z1 / z0 - 1) < 1e-4
    assert abs(w1 / OMEGA - 1) < 0.01 and abs(z1 / ZETA - 1) < 0.3  # the finite record's scatter: ~0.4 %, ~15 %


def expected_welch_h1(dt: float, segment: int, w: np.ndarray) -> np.ndarray:
    """The expectation of Welch's H1 (Hann segments of ``segment``
    samples) of the oscillator's displacement per a white force held over
    each sample, at ``w`` (m,) rad/s, as a ratio of expected spectra:
    ``sum_tau h_tau a_tau exp(-i w tau dt)``, ``h`` the exact sampled pulse
    response, ``a_tau = sum_m w_m w_(m + tau) / sum w_m^2`` the window's
    autocorrelation (independent of :func:`residues.window_moment`)."""
    from scipy.signal import get_window

    model = oscillator(M, C, K)
    pulse = np.zeros((segment, 1))
    pulse[0, 0] = 1.0
    h = respond(model, pulse, dt)["displacement"][:, 0]  # the response at t_k to 1 N held over [0, dt)
    win = get_window("hann", segment, fftbins=True)
    a = np.correlate(win, win, mode="full")[segment - 1:] / np.sum(win**2)
    tau = np.arange(segment)
    return np.exp(-1j * np.outer(w, tau) * dt) @ (h * a)


def test_the_welch_window_smoothing_is_fitted_with_the_pole():
    # Hann segments of 8.192 s put 13 lines in the 10 rad/s half-power band:
    # the estimate's resonance is wider: zeta +0.6 % if fitted as H itself
    from scipy.signal import get_window

    from structbench.identifier.modal import residues as rf

    dt, segment = 1e-3, 8192
    w = 2 * np.pi * np.arange(1, segment // 2) / (segment * dt)
    w = w[(w > 50.0) & (w < 150.0)]
    H = expected_welch_h1(dt, segment, w)[None, :]
    sigma = 1e-3 * np.abs(H)
    start = rf.poles_of(np.array([OMEGA * 1.01]), np.array([ZETA * 1.1]))
    mu2 = rf.window_moment(get_window("hann", segment, fftbins=True), dt)
    assert mu2 == pytest.approx(4 * np.pi**2 / (3 * (segment * dt) ** 2), rel=1e-3)
    fitted, moved = rf.refine(w, H, sigma, dt, start, np.array([0]), mu2=mu2)
    plain, _ = rf.refine(w, H, sigma, dt, start, np.array([0]))
    assert moved.all()
    zeta = -fitted.poles.real / np.abs(fitted.poles)
    assert abs(np.abs(fitted.poles[0]) / OMEGA - 1) < 1e-5
    assert abs(zeta[0] / ZETA - 1) < 2e-4  # the next term: (mu2 / (zeta omega)^2)^2 ~ 1e-4
    assert -plain.poles[0].real / np.abs(plain.poles[0]) / ZETA - 1 > 3e-3  # without: +0.59 %


def test_input_poles_reports_the_frf_fits_poles_with_their_errors():
    # displacement and force, 2 % noise on both, 60 s: the FRF fit's pole
    # against the closed form, and the run's headline values are that pole's
    model = oscillator(M, C, K)
    force = np.random.default_rng(5).standard_normal((60_000, 1))
    response = respond(model, force, 1e-3)
    trace = memory_trace(model, response, 1e-3, [("displacement", 1, "x"), ("force", 1, "x")],
                         noise={"displacement": 0.02, "force": 0.02}, seed=6)
    ssi = identify([trace], uncertainty="off", input="on")
    io = identify([trace], uncertainty="off", input="poles")
    fit = io.details["input_output"]
    j = int(np.argmin(np.abs(np.asarray(io.omega) - OMEGA)))
    assert fit["headline"][j] and io.omega[j] == fit["omega"][j] and io.damping_std[j] == fit["damping_std"][j]
    assert io.details["ssi"]["omega"] == ssi.omega and io.eigenvalues[j] == pytest.approx(io.omega[j] ** 2)
    assert abs(io.omega[j] - OMEGA) < 4 * io.omega_std[j] and abs(io.omega[j] / OMEGA - 1) < 5e-4
    assert abs(io.damping[j] - ZETA) < 4 * io.damping_std[j] and abs(io.damping[j] / ZETA - 1) < 0.05
