"""Held-out records (``modal_fuzz.unseen_record``) as a lab would mangle
them, through ``modal.identify``: per kind of mangling, how many records
crash (any exception but ``IdentificationError``), are refused, give a
non-finite error or invent a mode (reported over 5 % from every true one).

Kinds (``rng`` a numpy Generator seeded with the record's seed):

- ``brick``: every DFT line outside a random band set to zero (an FFT filter)
- ``butter``: 4th-order Butterworth band-pass, zero phase (``sosfiltfilt``), random band
- ``daq``: an anti-alias filter (255-tap Kaiser FIR, cut at 0.85 of Nyquist, zero phase) and an
  ADC's white noise at 1e-5 of the RMS
- ``decimate``: ``scipy.signal.decimate`` by 2-5 (order-8 Chebyshev, zero phase)
- ``upsample``: ``scipy.signal.resample`` to twice the rate (FFT: the top half left empty)
- ``offset``, ``drift``: a constant of 10 RMS, a ramp of +-3 RMS added
- ``quantise``: 12 and 8 bits over each channel's range
- ``dead``: one channel set to zero; ``twice``: the first channel logged again
- ``clip``: clipped at 2 and 3 RMS
- ``float32``, ``spike`` (one sample of 100 RMS), ``tiny``/``huge`` (times 1e-12 / 1e12)

Seeds 1,025,000-1,025,799 (spent as tuning seeds) were swept while the
twenty-third round's changes were made, 1,025,000-1,025,039 while the
twenty-fourth round's band edges were chosen (docs/modal-method.md).

    python benchmarks/modal_odd_records.py [--first 1026000] [--seeds 20] [--kind daq --kind clip ...]
"""
from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).parent))
from modal_fuzz import unseen_record, unseen_trace  # noqa: E402

from structbench.identifier import modal  # noqa: E402
from structbench.identifier.errors import IdentificationError  # noqa: E402


def _rms(y: np.ndarray) -> np.ndarray:
    return y.std(axis=1, keepdims=True)


def brick(y, dt, rng):
    n = y.shape[1]
    Y = np.fft.rfft(y, axis=1)
    w = 2 * np.pi * np.fft.rfftfreq(n, dt)
    lo, hi = np.sort(rng.uniform(0, w[-1], 2))
    Y[:, (w < lo) | (w > hi)] = 0
    return [(np.fft.irfft(Y, n, axis=1), dt)]


def butter(y, dt, rng):
    nyquist = np.pi / dt
    band = np.sort(rng.uniform(0.02, 0.9, 2)) * nyquist
    sos = signal.butter(4, band, btype="bandpass", fs=2 * nyquist, output="sos")
    return [(signal.sosfiltfilt(sos, y, axis=1), dt)] if y.shape[1] > 3 * (2 * len(sos) + 1) else []


def daq(y, dt, rng):
    taps = signal.firwin(255, 0.85, window=("kaiser", 10.0))
    out = signal.filtfilt(taps, [1.0], y, axis=1, padlen=min(765, y.shape[1] - 1))
    return [(out + 1e-5 * _rms(out) * rng.standard_normal(out.shape), dt)]


def decimate(y, dt, rng):
    q = int(rng.integers(2, 6))
    return [(signal.decimate(y, q, axis=1), dt * q)] if y.shape[1] > 27 * q else []


def upsample(y, dt, rng):
    return [(signal.resample(y, 2 * y.shape[1], axis=1), dt / 2)]


def offset(y, dt, rng):
    return [(y + 10 * _rms(y) * rng.standard_normal((y.shape[0], 1)), dt)]


def drift(y, dt, rng):
    return [(y + 3 * _rms(y) * np.linspace(-1, 1, y.shape[1]), dt)]


def quantise(y, dt, rng):
    step = np.abs(y).max(axis=1, keepdims=True)
    return [(np.round(y / (step / 2**b)) * (step / 2**b), dt) for b in (11, 7)]


def dead(y, dt, rng):
    y = y.copy()
    y[rng.integers(y.shape[0])] = 0
    return [(y, dt)]


def twice(y, dt, rng):
    return [(np.vstack([y, y[:1]]), dt)]


def clip(y, dt, rng):
    return [(np.clip(y, -k * _rms(y), k * _rms(y)), dt) for k in (2.0, 3.0)]


def float32(y, dt, rng):
    return [(y.astype(np.float32).astype(float), dt)]


def spike(y, dt, rng):
    y = y.copy()
    y[:, rng.integers(y.shape[1])] += 100 * _rms(y)[:, 0]
    return [(y, dt)]


def tiny(y, dt, rng):
    return [(y * 1e-12, dt)]


def huge(y, dt, rng):
    return [(y * 1e12, dt)]


KINDS = {f.__name__: f for f in (brick, butter, daq, decimate, upsample, offset, drift, quantise, dead, twice, clip,
                                  float32, spike, tiny, huge)}


def outcome(rec: dict, y: np.ndarray, dt: float) -> str:
    """``crashed: ...``, ``refused``, ``non-finite`` or ``invented N`` / ``ok`` of one mangled record."""
    m = y.shape[0]
    mangled = rec | {"y": y, "dt": dt, "quantities": np.resize(rec["quantities"], m),
                     "noise": np.resize(rec["noise"], m)}
    try:
        result = modal.identify([unseen_trace(mangled)])
    except IdentificationError:
        return "refused"
    except Exception as err:  # noqa: BLE001 - what this benchmark counts
        return f"crashed: {err!r}"[:160]
    if not np.all(np.isfinite(result.omega_std)):
        return "non-finite"
    far = [w for w in result.omega if not np.any(np.abs(w - rec["omega"]) <= 0.05 * rec["omega"])]
    return f"invented {len(far)}" if far else "ok"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--first", type=int, default=1_026_000)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--kind", action="append", choices=sorted(KINDS), help="default: every kind")
    args = parser.parse_args()
    kinds = args.kind or list(KINDS)
    tally: dict[str, collections.Counter] = {k: collections.Counter() for k in kinds}
    for seed in range(args.first, args.first + args.seeds):
        rec = unseen_record(seed)
        for kind in kinds:
            for y, dt in KINDS[kind](rec["y"], rec["dt"], np.random.default_rng(seed)):
                result = outcome(rec, y, dt)
                if result.startswith("crashed"):
                    print(f"seed {seed} {kind}: {result}", flush=True)
                counts = tally[kind]
                counts["records"] += 1
                counts[result.split()[0].rstrip(":")] += 1
                counts["invented modes"] += int(result.split()[1]) if result.startswith("invented") else 0
    print(f"seeds {args.first}-{args.first + args.seeds - 1}: per kind, records / crashed / refused / non-finite / "
          "records with an invented mode (modes)")
    for kind, c in tally.items():
        print(f"{kind:10s} {c['records']:4d} {c['crashed']:4d} {c['refused']:4d} {c['non-finite']:4d} "
              f"{c['invented']:4d} ({c['invented modes']})")


if __name__ == "__main__":
    main()
