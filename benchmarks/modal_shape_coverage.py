"""Coverage of the modal method's stated errors per mode on the damage beam's random response (issue 23).

The record of ``campaigns/damage-baseline.toml`` simulated here directly
(not through the FMU, so that 40 records take minutes): the 25-element
cantilever of ``campaigns/cantilever-25.toml`` (Rayleigh damping, so real
modes), an unmeasured band-limited Gaussian force at the tip (RMS 10 N,
1-1500 rad/s, cut by FFT like ``bench/harness/excitation.RandomForce``),
5 velocity sensors (nodes 5, 10, 15, 20, 25, w), 2 % white sensor noise
(of each channel's RMS), ``dt`` = 0.002 s, 300 s. Each modal coordinate is
the exact zero-order-hold response of its mode, ``q'' + 2 zeta omega q' +
omega^2 q = phi_tip f``.

Per record and true mode ``r`` found (reported omega within 3 %), with the
reported shape ``b`` (m,), its stated errors ``s`` (``mode_shapes_std``)
and the true shape ``t`` at the sensors (largest entry 1):

    c = sum(b t / s^2) / sum(b^2 / s^2),   z_l = (c b_l - t_l) / s_l,
    chi^2 = sum_l z_l^2  ~ chi^2(m - 1) when the stated errors are right

(the statistic model updating forms: its shape residuals profile the scale
out). Printed per mode: how often found, the share of entries inside their
95 % interval (``|z_l| <= 1.96 sqrt(1 - h_l)``, ``h_l = t_l^2 / s_l^2 /
sum t^2 / s^2`` the leverage of the scale fit; 0.95 when right), the
median chi^2 over its chi^2(m - 1) median (1 when right), the RMS of the
standardised entries ``z_l / sqrt(1 - h_l)`` (achieved over stated
spread; 1 when right), and for omega the share of ``|omega - omega_true|
<= 1.96 omega_std`` and the RMS of ``(omega - omega_true) / omega_std``.

Seeds: 113-140 are tuning seeds (any constant of the shape errors chosen on
them); 777 + i (i < 40) is the set measured when the shape errors were
first stated (docs/results-format.md); held-out: 300-339.

Measured before the order scatter (tuning seeds 113-140, 28 records, code
of 2e7bcb6 with the working tree of the day): shape entries inside 95 %
for modes 1-10: 0.91 0.94 0.98 0.91 0.94 0.89 0.73 0.79 0.19 0.04; RMS of
the standardised entries 1.20 0.91 0.82 1.26 0.86 1.38 1.87 1.62 5.85
7.06; omega inside 95 %: 0.93-1.00 for modes 1-9, 0.57 for mode 10.
After (af74beb: the scatter over the model orders, and the reported
pole's distance and the out-of-phase part where they stand out; the
constants, MAD and the 0.999 test level, chosen on seeds 113-140 and the
synthetic of tests/test_modal_shape_errors.py, seeds 200-207), tuning
seeds 113-140: entries in 95 % 0.96 0.99 0.99 0.99 0.99 0.99 0.94 0.99
0.71 1.00; RMS z 0.84 0.77 0.73 0.66 0.53 0.62 0.96 0.73 2.15 0.47.
Held-out seeds 300-319, run once on af74beb (the same seeds with the
scatter terms switched off, i.e. the jackknife alone, in brackets):
entries in 95 % 0.97 (0.92), 0.97 (0.97), 0.95 (0.95), 1.00 (0.95), 0.99
(0.96), 0.98 (0.91), 0.91 (0.67), 0.94 (0.68), 0.66 (0.22), 1.00 (0.05);
RMS z 0.79 (1.05), 0.86 (0.94), 0.81 (0.85), 0.45 (0.73), 0.60 (0.92),
0.63 (1.76), 1.06 (3.07), 0.99 (2.49), 2.08 (5.61), 0.50 (7.54). Mode 9
stays understated: its shapes are biased alike at every order (0.01-0.05
of the largest entry, seeds 113-122) and stay real. omega (unchanged
here, identifier/modal/support.py): inside 95 % 0.95-1.00 for modes 1-9
with RMS z 0.29-0.80 (overstated up to 3.4 times for modes 3-9), mode 10
0.65 (RMS z 1.92).

    python benchmarks/modal_shape_coverage.py [--seeds 113-140] [--duration 300]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import scipy.linalg as la
from scipy.signal import lfilter
from scipy.stats import chi2

from structbench.identifier import modal
from structbench.identifier.io.traces import Channel, Trace
from structbench.models.toml_model import load_structure

ROOT = Path(__file__).resolve().parents[1]
NODES = (5, 10, 15, 20, 25)
DT, RMS, BAND, NOISE = 0.002, 10.0, (1.0, 1500.0), 0.02
MATCH = 0.03  # relative frequency window within which a reported mode is the true one


def beam() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """omega (n,) rad/s, zeta (n,), mass-normalised shapes at the sensors (5, n) and at the tip force (n,)."""
    s = load_structure(ROOT / "campaigns" / "cantilever-25.toml")
    md = s.modes()
    C = s.damping().toarray()
    zeta = np.einsum("ir,ij,jr->r", md.shapes, C, md.shapes) / (2 * md.omega)
    rows = [s.dof_index(n, "w") for n in NODES]
    return md.omega, zeta, md.shapes[rows], md.shapes[s.dof_index(25, "w")]


def record(seed: int, duration: float, omega: np.ndarray, zeta: np.ndarray, at: np.ndarray, tip: np.ndarray
           ) -> np.ndarray:
    """Velocities (5, n) m/s with sensor noise, the exact ZOH response to the tip force."""
    n = int(round(duration / DT))
    rng = np.random.default_rng(seed)
    spectrum = np.fft.rfft(rng.standard_normal(n))
    w = 2 * np.pi * np.fft.rfftfreq(n, DT)
    spectrum[(w < BAND[0]) | (w > BAND[1])] = 0.0
    f = np.fft.irfft(spectrum, n)
    f *= RMS / np.sqrt(np.mean(f**2))
    qdot = np.empty((omega.size, n))
    for r, (wr, zr) in enumerate(zip(omega, zeta)):
        A = np.array([[0.0, 1.0], [-wr**2, -2 * zr * wr]])
        E = la.expm(np.block([[A, np.array([[0.0], [1.0]])], [np.zeros((1, 3))]]) * DT)
        Ad, Bd = E[:2, :2], E[:2, 2]
        # velocity y_k = [0 1] x_k, x_{k+1} = Ad x_k + Bd u_k: y = [0 1] adj(zI - Ad) Bd / det(zI - Ad)
        den = np.array([1.0, -np.trace(Ad), np.linalg.det(Ad)])
        num = np.array([0.0, Bd[1], Ad[1, 0] * Bd[0] - Ad[0, 0] * Bd[1]])
        qdot[r] = lfilter(num, den, tip[r] * f)
    y = at @ qdot
    y += NOISE * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(y.shape)
    return y


def trace(y: np.ndarray) -> Trace:
    channels = {f"velocity_{node}_w": Channel(f"velocity_{node}_w", row, "velocity", "m/s", node, "w",
                                              np.full(3, np.nan), NOISE) for node, row in zip(NODES, y)}
    return Trace(Path("ambient.h5"), np.arange(y.shape[1]) * DT, DT, DT, channels, {},
                 {"test": "ambient", "repetition": 0, "structure": "cantilever-25"}, {"kind": "random"})


def statistics(result, omega: np.ndarray, truth: np.ndarray) -> list[tuple[int, float, float, float, np.ndarray]]:
    """Per true mode found: (mode, omega, omega_std, chi^2, standardised entries z_l / sqrt(1 - h_l))."""
    w = np.asarray(result.omega)
    out = []
    for r, wt in enumerate(omega):
        if not w.size:
            break
        i = int(np.argmin(np.abs(w - wt)))
        if abs(w[i] - wt) > MATCH * wt:
            continue
        b, s = np.asarray(result.mode_shapes[i]), np.asarray(result.mode_shapes_std[i])
        t = truth[:, r] / truth[np.argmax(np.abs(truth[:, r])), r]
        if not np.all(np.isfinite(s) & (s > 0)):
            continue
        c = np.sum(b * t / s**2) / np.sum(b * b / s**2)
        z = (c * b - t) / s
        h = (t / s) ** 2 / np.sum((t / s) ** 2)
        out.append((r, w[i], result.omega_std[i], float(np.sum(z**2)), z / np.sqrt(1 - h)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="113-140")
    parser.add_argument("--duration", type=float, default=300.0)
    args = parser.parse_args()
    a, _, b = args.seeds.partition("-")
    omega, zeta, at, tip = beam()
    rows: list[tuple] = []
    start = time.perf_counter()
    seeds = range(int(a), int(b or a) + 1)
    for seed in seeds:
        result = modal.identify([trace(record(seed, args.duration, omega, zeta, at, tip))])
        rows += statistics(result, omega, at)
    print(f"{len(seeds)} records of {args.duration:g} s, seeds {args.seeds}, {time.perf_counter() - start:.0f} s")
    print("mode  omega rad/s  found  shape entries in 95 %  chi2 median/expected  RMS z  "
          "omega in 95 %  RMS omega z")
    expected = chi2.median(len(NODES) - 1)
    for r in sorted({row[0] for row in rows}):
        mine = [row for row in rows if row[0] == r]
        z = np.concatenate([row[4] for row in mine])
        zw = np.array([(row[1] - omega[r]) / row[2] for row in mine])
        print(f"{r + 1:4d}  {omega[r]:11.2f}  {len(mine):5d}  {np.mean(np.abs(z) <= 1.96):21.2f}  "
              f"{np.median([row[3] for row in mine]) / expected:20.2f}  {np.sqrt(np.mean(z**2)):5.2f}  "
              f"{np.mean(np.abs(zw) <= 1.96):13.2f}  {np.sqrt(np.mean(zw**2)):11.2f}")


if __name__ == "__main__":
    main()
