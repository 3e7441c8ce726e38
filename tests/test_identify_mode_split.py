"""Close pairs of modes from free-decay records (identifier/mode_split.py and
the fits it uses): synthetic free decays with known poles and shapes
(benchmarks/modal_synth.free_decays), the modal method's SSI-cov modes as the start."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from modal_synth import free_decays
from structbench.identifier.modal.close_pairs.free_decay_fit import Group, basis, fit_poles, project
from structbench.identifier.modal.close_pairs.local_space import columns, local_space
from structbench.identifier.modal.close_pairs import free_start, split_close_modes, split_free_decays
from structbench.identifier.modal.ssi.poles import real_shapes
from structbench.identifier.io.traces import Trace

DT, N = 0.01, 10001  # 100 s
SHAPES = np.linalg.qr(np.random.default_rng(123).standard_normal((8, 3)))[0]  # orthonormal, 8 channels
PAIR = np.array([1.0, 1.0001, 1.7])  # rad/s: modes 1 and 2 are 0.01 % apart, (delta omega) T = 0.01


def split(records, omega, zeta=None):
    """split_close_modes from SSI-like modes: the given frequencies, no damping, the true shapes."""
    zeta = np.zeros(omega.size) if zeta is None else zeta
    shapes = SHAPES[:, [0, 2]] if omega.size == 2 else SHAPES[:, :omega.size]
    return split_close_modes(records, DT, omega, zeta, shapes.astype(complex), np.full(omega.size, np.nan),
                             np.full(omega.size, np.nan))


def mac(a, b):
    return (a @ b) ** 2 / (a @ a) / (b @ b)


def test_local_space_gives_the_residual_of_the_whole_record():
    """Poles near the center: the reduced residual plus the constant part
    outside the Taylor space is the full projected residual (numerically exact)."""
    rng = np.random.default_rng(1)
    t = np.arange(3001) * 0.02
    group = Group(t, rng.standard_normal((t.size, 5)) + np.cos(1.3 * t)[:, None])
    fixed = np.array([-0.01 + 0.7j, -0.02 + 2.1j])
    center = -0.005 + 1.3j
    pair = center + np.array([0.4 - 0.6j, -0.3 + 0.9j]) / t[-1]
    loc = local_space(group, fixed, center)
    e = columns(loc, pair)
    reduced = loc.zv - e @ np.linalg.lstsq(e, loc.zv, rcond=None)[0]
    full = project(group, basis(t, np.concatenate([fixed, pair]))).resid
    assert np.sum(reduced**2) + loc.outside.sum() == pytest.approx(np.sum(full**2), rel=1e-10)


def test_free_decay_fit_recovers_a_pole_exactly():
    """Variable projection, noise-free: one pole started 0.3 bins off comes back
    to its value with the other poles held (their residues free)."""
    poles = np.array([-0.002 + 1.2j, -0.01 + 0.6j, -0.004 + 2.0j])
    records = free_decays(np.abs(poles), -poles.real / np.abs(poles), SHAPES, np.array([[1.0, 0.7j, -0.4]]),
                          DT, N, 0.0, 0)
    group = Group(np.arange(N) * DT, records[0].T)
    start = poles[0] + 0.3j * 2 * np.pi / 100.0
    assert fit_poles([group], poles[1:], start[None], (1.1, 1.3))[0] == pytest.approx(poles[0], abs=1e-9)


def test_pair_001_percent_apart_resolved_from_two_records():
    """2 % noise; record 1 moves both modes alike, record 2 mostly the first:
    two modes within 0.002 % (and 4 standard errors), shapes MAC > 0.99, the
    third mode left as it was."""
    for seed in (1, 2):
        records = free_decays(PAIR, np.zeros(3), SHAPES, np.array([[1.0, 1.0, 0.5], [1.0, 0.2, 1.0]]), DT, N,
                              0.02, seed)
        out = split(records, np.array([1.00005, 1.7]))
        assert list(out.refined) == [True, True, False] and list(out.source) == [0, 0, 1]
        err = out.omega[:2] - PAIR[:2]
        assert np.all(np.abs(err) < 2e-5 * PAIR[:2]) and np.all(np.abs(err) < 4 * out.omega_std[:2])
        assert np.all(np.abs(out.zeta[:2]) < 4 * out.zeta_std[:2])
        shapes = real_shapes(out.shapes[:, :2])
        assert min(mac(shapes[:, a], SHAPES[:, a]) for a in range(2)) > 0.99
        assert out.omega[2] == 1.7


def test_pair_split_with_a_mode_missing_from_the_list():
    """A strong mode the SSI list lacks is fitted, so that its signal does not
    spoil the pair, and reported (source -1) at its frequency (within 0.001 %
    and 4 standard errors) and shape (MAC > 0.999)."""
    records = free_decays(PAIR, np.zeros(3), SHAPES, np.array([[1.0, 1.0, 2.0], [1.0, 0.2, 2.0]]), DT, N, 0.02, 3)
    out = split(records, np.array([1.00005]))
    assert out.omega.size == 3 and out.refined.all() and list(out.source) == [0, 0, -1]
    assert out.omega[:2] == pytest.approx(PAIR[:2], rel=2e-5)
    assert abs(out.omega[2] - PAIR[2]) < min(1e-5 * PAIR[2], 4 * out.omega_std[2])
    assert mac(real_shapes(out.shapes[:, 2:])[:, 0], SHAPES[:, 2]) > 0.999


def test_pair_missing_from_the_list_found_in_the_residual_and_split():
    """SSI lost the pair (0.01 % apart) altogether: the residual's peak is
    fitted and split, two modes within 0.002 % and MAC > 0.99; the listed mode stays as given."""
    for seed in (4, 5):
        records = free_decays(PAIR, np.zeros(3), SHAPES, np.array([[1.0, 1.0, 0.5], [1.0, 0.2, 1.0]]), DT, N,
                              0.02, seed)
        out = split_close_modes(records, DT, PAIR[2:], np.zeros(1), SHAPES[:, 2:].astype(complex),
                                np.full(1, np.nan), np.full(1, np.nan))
        assert list(out.source) == [-1, -1, 0] and list(out.refined) == [True, True, False]
        assert out.omega[:2] == pytest.approx(PAIR[:2], rel=2e-5) and out.omega[2] == PAIR[2]
        shapes = real_shapes(out.shapes[:, :2])
        assert min(mac(shapes[:, a], SHAPES[:, a]) for a in range(2)) > 0.99


def test_repeated_root_missing_from_the_list_reported_once():
    """A repeated root (two shapes, one pole; residues of rank two) that SSI
    lost is found in the residual and reported once, at its frequency within
    4 standard errors: no second mode invented."""
    omega = np.array([1.0, 1.0, 1.7])
    for seed in (1, 2):
        records = free_decays(omega, np.zeros(3), SHAPES, np.array([[1.0, 1.0, 0.5], [1.0, 0.2, 1.0]]), DT, N,
                              0.02, seed)
        out = split_close_modes(records, DT, omega[2:], np.zeros(1), SHAPES[:, 2:].astype(complex),
                                np.full(1, np.nan), np.full(1, np.nan))
        assert list(out.source) == [-1, 0] and abs(out.omega[0] - 1.0) < 4 * out.omega_std[0]


def test_noise_peak_in_the_residual_not_reported():
    """Two seeds whose white noise leaves a residual peak (near 297 and 145 rad/s)
    significant at level 0.01 but far above the DISCOVERY p-value: fitted,
    not reported; the listed modes stay as given."""
    omega = PAIR[[0, 2]]
    for seed in (23, 46):
        records = free_decays(omega, np.full(2, 0.001), SHAPES[:, [0, 2]], np.array([[1.0, 0.5], [0.3, 1.0]]),
                              DT, N, 0.02, seed)
        out = split(records, omega)
        assert list(out.omega) == list(omega) and not out.refined.any()


@pytest.mark.parametrize("participations", [np.array([[1.0, 0.5], [0.3, 1.0]]),  # one mode at 1 rad/s
                                            np.array([[1.0, 1.0, 0.5], [0.5, 0.5, 1.0]])])  # pair, one proportion
def test_nothing_split_that_the_records_cannot_separate(participations):
    """A genuine single mode, and a pair that both records move in the same
    proportion (no record tells its shapes apart): reported as one mode, as given."""
    omega = PAIR[[0, 2]] if participations.shape[1] == 2 else PAIR
    shapes = SHAPES[:, [0, 2]] if participations.shape[1] == 2 else SHAPES
    for seed in range(4):
        records = free_decays(omega, np.zeros(omega.size), shapes, participations, DT, N, 0.02, seed)
        out = split(records, np.array([1.00005, 1.7]))
        assert not out.refined.any() and list(out.omega) == [1.00005, 1.7]


def _trace(attrs: dict, step: float = 0.01) -> Trace:
    return Trace(Path("x.h5"), np.arange(3) * 0.01, 0.01, step, {}, {}, {}, attrs)


def test_free_start_from_the_excitation_attributes():
    pulse = {"kind": "impulse", "spec": [{"kind": "impulse", "time": 0.0, "method": "pulse"}]}
    assert free_start(_trace(pulse)) == 1  # free after the one-step pulse
    assert free_start(_trace(pulse, step=0.03)) == 3
    late = {"kind": "impulse", "spec": [{"kind": "impulse", "time": 0.5, "method": "initial-velocity"}]}
    assert free_start(_trace(late)) == 50
    assert free_start(_trace({"kind": "initial"})) == 0
    assert free_start(_trace({"kind": "impulse+initial"})) == 1
    assert free_start(_trace({"kind": "random"})) is None
    assert free_start(_trace({})) is None


def test_split_only_for_two_or_more_free_responses():
    records = free_decays(PAIR, np.zeros(3), SHAPES, np.array([[1.0, 1.0, 0.5], [1.0, 0.2, 1.0]]), DT, N, 0.02, 1)
    omega, zeta, shapes = np.array([1.00005, 1.7]), np.zeros(2), SHAPES[:, [0, 2]].astype(complex)
    se = np.full(2, 1e-4)
    free = _trace({"kind": "initial"})
    for traces, refine in (([free, free], "off"), ([free], "auto"),
                           ([free, dataclasses.replace(free, excitation_attrs={"kind": "random"})], "auto")):
        out = split_free_decays(traces, records[:len(traces)], DT, omega, zeta, shapes, se, se, refine)
        assert out.omega is omega and not out.refined.any()
    assert split_free_decays([free, free], records, DT, omega, zeta, shapes, se, se, "auto").refined.sum() == 2
