"""The modal method on random structures the bench has never seen: how many
true modes it finds, how many it invents, how accurate the rest are.

Each case (numpy ``default_rng(seed)``): 1-9 modes log-uniform in 1-100
rad/s, at least 3 % apart, damping ratios log-uniform in 0.2-5 %, 2-16
sensors with random orthonormal-ish shapes, sampling 1.5-4 times the
highest frequency's Nyquist rate, 2 % white noise on every channel.

- ``decay``: a free decay (benchmarks/modal_synth.free_decays) with
  participations falling as 1 / omega (as velocities after an impulse), at
  least 200 periods of the lowest mode and three decay times of the slowest;
- ``stationary``: every mode driven by its own white noise (unit RMS each),
  2000 periods of the lowest mode (at most 400,000 samples).

A true mode counts as found when a reported one is within 1 % of it; an
invented mode is a reported one within 1 % of none. In a free decay a mode
whose spectral peak is below the noise (``snr``: its peak power over the
noise's in the periodogram, under 10) cannot be seen by any method and is
listed apart. Last, how often the stated 95 % intervals of the found
modes' frequencies and damping ratios cover the truth.

    python benchmarks/modal_fuzz.py [--kind decay|stationary] [--seeds 40] [--first 0]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

sys.path.insert(0, str(Path(__file__).parent))
from modal_synth import free_decays  # noqa: E402

from structbench.identifier import modal  # noqa: E402
from structbench.identifier.errors import IdentificationError  # noqa: E402
from structbench.identifier.io.traces import Channel, Trace  # noqa: E402

NOISE = 0.02


def trace(y: np.ndarray, dt: float) -> Trace:
    """An in-memory trace of velocity records ``y`` (m, n) at points 1..m."""
    channels = {f"velocity_{i + 1}_w": Channel(f"velocity_{i + 1}_w", row, "velocity", "m/s", i + 1, "w",
                                               np.full(3, np.nan), NOISE) for i, row in enumerate(y)}
    return Trace(Path("fuzz.h5"), np.arange(y.shape[1]) * dt, dt, dt, channels, {},
                 {"test": "fuzz", "repetition": 0, "structure": "random"}, {})


def structure(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """omega (p,) rad/s, zeta (p,), unit shapes (m, p) and dt s of one random structure."""
    p, m = int(rng.integers(1, 10)), int(rng.integers(2, 17))
    while True:
        omega = np.sort(np.exp(rng.uniform(0.0, np.log(100.0), p)))
        if p == 1 or np.min(np.diff(omega) / omega[1:]) > 0.03:
            break
    zeta = np.exp(rng.uniform(np.log(0.002), np.log(0.05), p))
    dt = float(np.pi / (omega.max() * rng.uniform(1.5, 4.0)))
    shapes = rng.standard_normal((m, p))
    return omega, zeta, shapes / np.linalg.norm(shapes, axis=0), dt


def decay(rng: np.random.Generator, seed: int):
    """Records (m, n), omega, zeta, dt and per-mode snr of a free decay."""
    omega, zeta, shapes, dt = structure(rng)
    T = min(max(3.0 / (zeta.min() * omega.min()), 400 * np.pi / omega.min()), 4000.0)
    n = int(min(T / dt, 200_000))
    part = np.abs(rng.standard_normal(omega.size)) * omega.min() / omega * np.exp(2j * np.pi * rng.random(omega.size))
    clean = free_decays(omega, zeta, shapes, part[None, :], dt, n, 0.0, seed)[0]
    rms = np.sqrt(np.mean(clean**2, axis=1))
    y = clean + NOISE * rms[:, None] * np.random.default_rng(seed).standard_normal(clean.shape)  # as free_decays adds it
    noise_power = n * np.sum((NOISE * rms) ** 2)
    length = np.minimum(1.0 / (2.0 * zeta * omega * dt), n)  # samples the mode lasts
    return y, omega, zeta, dt, np.abs(part) ** 2 * length**2 / 4.0 / noise_power


def stationary(rng: np.random.Generator, seed: int):
    """Records (m, n), omega, zeta, dt of a response to white noise on every mode."""
    omega, zeta, shapes, dt = structure(rng)
    n = int(min(4000 * np.pi / omega.min() / dt, 400_000))
    clean = np.zeros((shapes.shape[0], n))
    for a in range(omega.size):
        mu = np.exp((-zeta[a] * omega[a] + 1j * omega[a] * np.sqrt(1 - zeta[a] ** 2)) * dt)
        q = lfilter([0.0, 1.0], np.poly([mu, mu.conjugate()]).real, rng.standard_normal(n))
        clean += np.outer(shapes[:, a], q / np.std(q))
    y = clean + NOISE * np.std(clean, axis=1, keepdims=True) * rng.standard_normal(clean.shape)
    return y, omega, zeta, dt, np.full(omega.size, np.inf)


def run(kind: str, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    y, omega, zeta, dt, snr = (decay if kind == "decay" else stationary)(rng, seed)
    row = {"seed": seed, "modes": omega.size, "sensors": y.shape[0], "samples": y.shape[1]}
    try:
        result = modal.identify([trace(y, dt)])
    except IdentificationError as exc:
        return row | {"error": str(exc)}
    found = np.array(result.omega)
    near = [int(np.argmin(np.abs(found - w))) if found.size else -1 for w in omega]
    hit = np.array([i >= 0 and abs(found[i] - w) < 0.01 * w for i, w in zip(near, omega)])
    invented = int(sum(np.min(np.abs(omega - w) / omega) >= 0.01 for w in found))
    visible = snr >= 10
    pairs = [(i, w, z) for i, w, z, h in zip(near, omega, zeta, hit) if h]
    ferr = [abs(found[i] / w - 1) * 100 for i, w, _ in pairs]
    seen = [e for e, v in zip(ferr, visible[hit]) if v]
    zerr = [abs(result.damping[i] / z - 1) * 100 for i, _, z in pairs]
    covered = [abs(est - true) <= 1.96 * se for i, w, z in pairs
               for est, se, true in ((result.omega[i], result.omega_std[i], w),
                                     (result.damping[i], result.damping_std[i], z)) if np.isfinite(se)]
    return row | {"found": int(hit[visible].sum()), "visible": int(visible.sum()),
                  "hidden found": int(hit[~visible].sum()), "hidden": int((~visible).sum()),
                  "invented": invented, "freq %": max(ferr, default=np.nan),
                  "visible freq %": max(seen, default=np.nan), "damping %": max(zerr, default=np.nan),
                  "covered": int(sum(covered)), "intervals": len(covered)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kind", choices=["decay", "stationary"], default="decay")
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--first", type=int, default=0)
    args = parser.parse_args(argv)
    rows = []
    for seed in range(args.first, args.first + args.seeds):
        row = run(args.kind, seed)
        rows.append(row)
        print(" ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()), flush=True)
    ok = [r for r in rows if "error" not in r]
    print(f"\n{args.kind}: {len(rows)} structures, {len(rows) - len(ok)} errors; visible modes found "
          f"{sum(r['found'] for r in ok)}/{sum(r['visible'] for r in ok)}, hidden ones found "
          f"{sum(r['hidden found'] for r in ok)}/{sum(r['hidden'] for r in ok)}; invented modes "
          f"{sum(r['invented'] for r in ok)} in {sum(r['invented'] > 0 for r in ok)} structures; "
          f"worst frequency error per structure median {np.nanmedian([r['freq %'] for r in ok]):.3f} % "
          f"(of the visible modes median {np.nanmedian([r['visible freq %'] for r in ok]):.3f} %, "
          f"max {np.nanmax([r['visible freq %'] for r in ok]):.3f} %), "
          f"worst damping error median {np.nanmedian([r['damping %'] for r in ok]):.1f} %; 95 % intervals "
          f"(frequency and damping) cover the truth in {sum(r['covered'] for r in ok)}/"
          f"{sum(r['intervals'] for r in ok)}")


if __name__ == "__main__":
    main()
