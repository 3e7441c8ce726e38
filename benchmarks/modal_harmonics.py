"""Harmonics in operational records: does the modal method list them apart
from the modes, and are the modes as accurate as without them?

Synthetic traces written directly (modal superposition, exact zero-order-hold
discretisation per mode, ``benchmarks/modal_synth.py``), not the FMUs: a
case is 1-3 s instead of a minute of simulation. Each case (numpy
``default_rng(seed)``) is one record with harmonics and the same record
without them (same random force, same sensor noise, 2 % of the random
response's RMS per channel), identified by ``structbench identify --method
modal``'s function with its defaults:

- ``beam``: the chapter 5 beam (``ch5-simply-supported-beam``) with
  campaigns/ch5-damped.toml's damping ratios (0.8-5 %), a band-limited
  random force (0-30 rad/s, 1 N RMS) at point 1, 10 velocity sensors,
  ``dt`` 0.1 s, 2 hours. Its band is 0.1-22 rad/s, far below 50 Hz: the
  harmonics are multiples of a base ``omega_0`` uniform in 1.5-5 rad/s
  (three of the multiples below 28 rad/s, as mains gives 50, 150, 250 Hz);
- ``ch3``: the chapter 3 beam (the issue names it), its damped variant
  ``ch3-damped-beam`` (element damping 0.05 times stiffness: zeta_r =
  0.025 omega_r s) on soft supports: its 25 flexible underdamped modes
  (0.06-38.7 rad/s, zeta 0.16-97 %), a velocity sensor at every node's w
  (16), a band-limited random force (0-30 rad/s, 1 N RMS) at node 7 w,
  ``dt`` 0.1 s, 2 hours, harmonics as the ch5 beam's (its modes lie far
  below 50 Hz too). Its heavily damped modes are not resolved (about a
  quarter of its modes are found; mode 1, 0.7 decay times in the record,
  can be listed as a harmonic);
- ``frame``: a random shear frame not in the repository: 3-8 storeys,
  storey masses 500-2000 kg and stiffnesses k0 (0.5-1.5) N/m with ``k0``
  set so that mode 1 is at 2-10 Hz, modal damping ratios log-uniform in
  0.5-5 %, independent random forces (0-200 Hz, 100 N RMS) at every
  storey, a velocity sensor per storey, ``dt`` 1/500 s, 300 s. Harmonics:
  two or three of 50, 100, 150, 200 Hz (mains multiples) from a machine on a
  random storey.

The harmonics are in steady state (the machine ran before the record
began; a record that starts with the machine, as a campaign's
``disturbance`` item does, also holds its start-up transient, a free decay
of the modes near each harmonic). Amplitudes: each harmonic's force (N,
random phase) is set so that its
steady response (the FRF, power summed over the sensors) is ``R`` times the
RMS of the random response in the 1/3-octave band around it (likewise
summed), ``R`` log-uniform in 0.1-10. A harmonic *sits on a mode* when it is
within the mode's half-power band ``|omega_h - omega_r| < zeta_r omega_r``.

Per case: harmonics listed (an entry of ``details.harmonics`` within 0.2 %
or two spectral lines), harmonics reported as modes (a reported mode not
paired with a true mode, within 1 % of a harmonic), true modes reported as
harmonics, and the frequency and damping errors of the true modes found with
and without the harmonics (:func:`structbench.evaluation.modal_scores.modal_scores`).

Seeds 0-23 (beam) and 0-15 (frame) were used while the thresholds of
``identifier/modal/harmonics.py`` were first chosen, and seeds 1000-1099
were the first held-out set (figures below). Its four harmonics reported
as modes (beam 1052, 1075, 1099, frame 1065) were then diagnosed on those
seeds: two weak harmonics on a mode's band got an SSI pole of damping 0
(1e-6 to 3e-5, under one decay time in the record) whose kurtosis did not
reach the 0.3 % near-zero test's bar; two got a damped pole (0.12 %,
0.23 %) fitted to the line beside or on a broad mode. The near-zero damping
became relative to the record (decay times ``|zeta| omega T``) and the
``line`` test (a pole's peak against a mode's of its half-width) was added.
Its thresholds come from the periodogram's exponential scatter (a mode's
line 15 times over its expected peak: about 1e-4 per line of its band) and
the support tests' least decay times, not from fits to those seeds (whose
pole features were looked at, so their figures for the new code are not
held out); they were checked on seeds 0-23 / 0-15, on new tuning seeds
3000-3024 (beam) and 3000-3031 (frame; the 3000-3049 planned did not fit
the session) and on
benchmarks/modal_fuzz.py's tuning seeds (100,000-100,199, the
supported-modes side). The figures of
docs/modal-method.md are fresh seeds 2000-2099, run once on the final code:

    python benchmarks/modal_harmonics.py --structure beam --first 2000 --seeds 100 --uncertainty off
    python benchmarks/modal_harmonics.py --structure frame --first 2000 --seeds 100 --uncertainty off

First held-out set (seeds 1000-1099, the code before the fix): beam 293 of
300 harmonics listed (97.7 %), 3 reported as modes, modes found 80.4 %
without and 77.7 % with harmonics, median abs frequency error 0.103 % and
0.104 %; frame 248 of 249 (99.6 %), 1 reported as a mode, modes found
100 % either way, 0.060 % and 0.059 %.

Fresh held-out set (seeds 2000-2099, final code, run once; 45 minutes each
on a machine loaded by other jobs): beam 290 of 300 harmonics listed
(96.7 %), 4 reported as modes, 4 true modes listed as harmonics, modes
found 81.1 % without and 77.3 % with harmonics, median abs frequency error
0.114 % and 0.112 %; frame 249 of 251 (99.2 %), 2 reported as modes, none
listed as harmonics, modes found 100 % either way, 0.057 % and 0.057 %.
The zero target for harmonics reported as modes is missed (6 in 200):
docs/modal-method.md says why.

Second round (the coherent share, signed damping of still poles, the line
test's threshold over its lines; docs/modal-method.md): tuned on seeds
1000-1099 and 2000-2099 (the wrong cases of both sets looked at one by
one) and on a Monte Carlo of one mode's random response (seeds
10000-10149). Held out: seeds 3000-3099, run once on the code of commit
a9b9037 (beam 3000-3024 and frame 3000-3031 had been run as tuning seeds
of the first round, before that code existed; they and fresh beam seeds
5000-5029 ran on e2d440e, which followed: see docs); the machine was shared by
other jobs (load 20 on 2 cores), so the cases were run in four processes
and the figures cover the cases that ended before the deadline:

    python benchmarks/modal_harmonics.py --structure beam --first 3050 --seeds 50 --uncertainty off --save beam.jsonl
    python benchmarks/modal_harmonics.py --summarise beam.jsonl

Figures (docs/modal-method.md has the table): beam 3000-3099 292 of 300
harmonics listed (97.3 %), 3 reported as modes (3026, 3052, 3058, on
a9b9037), no mode listed as a harmonic, modes found 82.1 % without and
77.7 % with harmonics; frame 3000-3099 256 of 260 (98.5 %), 1 reported
as a mode (3021, e2d440e), modes 100 %; beam 5000-5029 (fresh,
e2d440e) 90 of 90, none as modes.

Fourth round (the spatial line test, identifier/modal/harmonics_spatial.py;
docs/modal-method.md): tuned on ch3 seeds 9000-9007 and the ch3 records of
9100-9125 and 9200-9217 that had missed a harmonic (9105, 9107, 9108, 9111,
9114, 9200, 9208, 9214, 9215), beam 6000-6022 (14 records) and frame
6000-6019 (12); single-input white records (tests/test_modal_harmonics_spatial.py,
seeds 0-3) for the null law. Fresh seeds on a
clean copy of commit 10714ee, run once each, two processes at load 8-9:

    python benchmarks/modal_harmonics.py --structure ch3 --first 9300 --seeds 100 --uncertainty off --save ch3.jsonl
    python benchmarks/modal_harmonics.py --structure frame --first 7300 --seeds 100 --uncertainty off --save frame.jsonl

ch3 9300-9399: 298 of 300 harmonics listed (99.3 %), 1 reported as a mode
(9354), 30 modes listed as harmonics (mode 1, alike with and without
harmonics), 32 lines in the 100 records without harmonics (31 mode 1),
modes found 27.6 % / 27.6 % without / with, median abs frequency error
0.189 % / 0.189 %, damping 9.46 % / 9.46 %. frame 7300-7399: 247 of 247
(100 %), none as modes, 7 modes listed as harmonics, 13 lines counted in
the records without harmonics (plus 7 at 200 Hz that the scorer takes
for the harmonic of the record with harmonics: the spatial test lists a
false line at the random forces' 200 Hz band edge in 9 records), modes
100 % / 100 %, 0.059 % / 0.059 %, damping 4.64 % / 4.60 %.

Fifth round (the RISE guard gives way when a pole's band keeps no peak
once its line is out; the spatial test takes the smallest of its two-sided
and one-sided ratios, so that the frame's 200 Hz band edge is no line;
docs/modal-method.md): tuned on ch3 9354 and the frame's 7300-7399 records
without harmonics (both looked at after the fourth round's run), on
synthetic records (tests/test_modal_harmonics_poles.py: peak_left's null
law, seeds 0-15 and 100-105, checked on 0-39; tests/test_modal_harmonics_spatial.py:
band-limited records, seeds 0-8; the spatial test's null records 10-29)
(the checks on earlier tuning seeds run in that session were lost with
its machine and are not quoted). Fresh seeds,
never looked at before the run, on a clean copy of cc7a31b, run once
each with --uncertainty off (9400-9499 and 7400-7499 were started in the
session before; their results were lost with its machine and are not
quoted):

    python benchmarks/modal_harmonics.py --structure ch3 --first 9500 --seeds 100 --uncertainty off --save ch3.jsonl
    python benchmarks/modal_harmonics.py --structure frame --first 7500 --seeds 100 --uncertainty off --save frame.jsonl

ch3 9500-9599: 298 of 300 harmonics listed (99.3 %), 1 reported as a mode
(9576), 43 modes listed as harmonics (as many lines in the records without
harmonics), modes found 28.2 % / 28.2 %, median abs frequency error 0.198
% / 0.202 %. frame 7500-7599: 249 of 251 (99.2 %), 1 reported as a mode
(7504), 2 modes listed as harmonics, 7 lines in the records without
harmonics (none at 200 Hz), modes 100 % / 100 %, 0.063 % / 0.064 %.

Sixth round (the coherent share and peak_left take the sinusoid at the
band's strongest whitened line; the coherent test also for a broad pole
whose band keeps no peak without its line; docs/modal-method.md): tuned on
ch3 9576 and frame 7504 (looked at after the fifth round's run) and the
synthetic records of tests/test_modal_harmonics_whitened.py (seeds 0-9,
3-4), checked on ch3 9500-9599 and frame 7500-7599.
Fresh seeds ch3 9600-9699 and frame 7600-7699, run once each on a clean
copy of the final code (6cc18eb; the frame also on 47e7ec6, identical):
ch3 300 of 300 harmonics listed, none reported as modes, 35 modes listed
as harmonics (36 lines in the records without harmonics), modes found
27.9 % / 27.9 %, median abs frequency error 0.200 % / 0.201 %; frame 237
of 237, none as modes, 7 modes listed as harmonics (the same 7 without),
modes 100 % / 100 %, 0.061 % / 0.061 %.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as la
from scipy.signal import lfilter

sys.path.insert(0, str(Path(__file__).parent))
from modal_synth import _mode_filter, band_force  # noqa: E402

from structbench.evaluation.modal_scores import harmonic_scores, modal_scores  # noqa: E402
from structbench.identifier import modal  # noqa: E402
from structbench.identifier.errors import IdentificationError  # noqa: E402
from structbench.identifier.io.traces import Channel, Trace  # noqa: E402
from structbench.models import load_model  # noqa: E402

NOISE = 0.02
BEAM_ZETA = np.array([0.02, 0.015, 0.01, 0.008, 0.01, 0.012, 0.015, 0.018, 0.02, 0.025,
                      0.03, 0.035, 0.04, 0.045, 0.05])  # campaigns/ch5-damped.toml
THIRD_OCTAVE = 2 ** (1 / 6)


def velocity(omega: np.ndarray, zeta: np.ndarray, shapes: np.ndarray, modal_force: np.ndarray,
             dt: float) -> np.ndarray:
    """Velocities (m, n) at the sensors of modes ``omega`` (p,), ``zeta``,
    ``shapes`` (m, p) under modal forces (p, n) held over each step."""
    qd = np.empty_like(modal_force)
    for r, (w, z) in enumerate(zip(omega, zeta)):
        Ad, Bd = _mode_filter(w, z, dt)
        num_v = np.r_[0.0, Bd[1], Ad[1, 0] * Bd[0] - Ad[0, 0] * Bd[1]]
        qd[r] = lfilter(num_v, np.poly(Ad), modal_force[r])
    return shapes @ qd


def frf_velocity(omega: np.ndarray, zeta: np.ndarray, shapes: np.ndarray, load: np.ndarray,
                 w: float) -> np.ndarray:
    """Complex velocity amplitudes (m,) per N of force ``load`` (p,) in modal
    coordinates at ``w`` rad/s."""
    return shapes @ (1j * w * load / (omega**2 - w**2 + 2j * zeta * omega * w))


def band_power(y: np.ndarray, dt: float, w: float) -> float:
    """Power of ``y`` (m, n) in the 1/3-octave band around ``w`` rad/s, summed over the channels."""
    Y = np.fft.rfft(y, axis=1)
    f = 2 * np.pi * np.fft.rfftfreq(y.shape[1], dt)
    band = (f >= w / THIRD_OCTAVE) & (f <= w * THIRD_OCTAVE)
    return float(2 * np.sum(np.abs(Y[:, band])**2) / y.shape[1]**2)


def structure(kind: str, rng: np.random.Generator) -> dict:
    """Modes (omega, zeta, shapes at the sensors (m, p), all DOF shapes), dt, n,
    the random modal force (p, n) and the harmonics' frequencies and DOF."""
    if kind == "beam":
        beam = load_model("ch5-simply-supported-beam")
        dt, n = 0.1, 72_001
        shapes = beam.shapes
        force = band_force(n, dt, (0.0, 30.0), 1.0, int(rng.integers(2**31)))
        w0 = rng.uniform(1.5, 5.0)
        multiples = np.arange(1, int(28.0 / w0) + 1)
        picks = np.sort(rng.choice(multiples, size=min(3, multiples.size), replace=False))
        return {"omega": beam.omega, "zeta": BEAM_ZETA, "shapes": shapes, "dt": dt, "n": n,
                "modal_force": np.outer(shapes[0], force), "harmonics": picks * w0,
                "at": int(rng.integers(shapes.shape[0]))}
    if kind == "ch3":
        return _ch3(rng)
    storeys = int(rng.integers(3, 9))
    mass = rng.uniform(500, 2000, storeys)
    k = rng.uniform(0.5, 1.5, storeys)
    K = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    lam, phi = la.eigh(K, np.diag(mass))
    scale = (2 * np.pi * rng.uniform(2.0, 10.0))**2 / lam[0]
    omega = np.sqrt(lam * scale)
    dt, n = 1 / 500, 150_001
    forces = np.vstack([band_force(n, dt, (0.0, 2 * np.pi * 200), 100.0, int(s))
                        for s in rng.integers(2**31, size=storeys)])
    hz = np.sort(rng.choice([50.0, 100.0, 150.0, 200.0], size=int(rng.integers(2, 4)), replace=False))
    return {"omega": omega, "zeta": np.exp(rng.uniform(np.log(0.005), np.log(0.05), storeys)), "shapes": phi,
            "dt": dt, "n": n, "modal_force": phi.T @ forces, "harmonics": 2 * np.pi * hz,
            "at": int(rng.integers(storeys))}


def _ch3(rng: np.random.Generator) -> dict:
    """The chapter 3 beam's damped variant (``ch3-damped-beam``: element
    damping 0.05 times stiffness, so zeta_r = 0.025 omega_r s) on soft
    supports: its flexible underdamped modes (0.06-38.7 rad/s, zeta
    0.16-97 %; the rigid-body and overdamped ones left out), a velocity
    sensor at every node's w (16), a band-limited random force (0-30 rad/s,
    1 N RMS) at node 7 (w, as the chapter's harmonic test), ``dt`` 0.1 s, 2
    hours; harmonics as the ch5 beam's (multiples of a base in 1.5-5 rad/s
    below 28 rad/s) at a random node."""
    beam = load_model("ch3-damped-beam")
    K, M, C = (np.asarray(x.toarray() if hasattr(x, "toarray") else x) for x in
               (beam.stiffness(), beam.mass(), beam.damping()))
    lam, phi = la.eigh(K, M)
    omega = np.sqrt(np.clip(lam, 0.0, None))
    zeta = np.diag(phi.T @ C @ phi) / (2 * np.maximum(omega, 1e-12))
    keep = (omega > 1e-4 * omega.max()) & (zeta < 1.0)
    omega, zeta, phi = omega[keep], zeta[keep], phi[:, keep]
    nodes = sorted({node for node, direction in beam.dofs if direction == "w"})
    shapes = phi[[beam.dof_index(node, "w") for node in nodes]]
    dt, n = 0.1, 72_001
    force = band_force(n, dt, (0.0, 30.0), 1.0, int(rng.integers(2**31)))
    w0 = rng.uniform(1.5, 5.0)
    multiples = np.arange(1, int(28.0 / w0) + 1)
    picks = np.sort(rng.choice(multiples, size=min(3, multiples.size), replace=False))
    return {"omega": omega, "zeta": zeta, "shapes": shapes, "dt": dt, "n": n,
            "modal_force": np.outer(phi[beam.dof_index(7, "w")], force), "harmonics": picks * w0,
            "at": int(rng.integers(shapes.shape[0]))}


def case(kind: str, seed: int) -> dict:
    """Records with and without harmonics and the harmonics' truth."""
    rng = np.random.default_rng(seed)
    s = structure(kind, rng)
    omega, zeta, shapes, dt, n = s["omega"], s["zeta"], s["shapes"], s["dt"], s["n"]
    random = velocity(omega, zeta, shapes, s["modal_force"], dt)
    t = np.arange(n) * dt
    total = random.copy()
    truth = []
    for w in s["harmonics"]:
        ratio = float(np.exp(rng.uniform(np.log(0.1), np.log(10.0))))
        h = frf_velocity(omega, zeta, shapes, shapes[s["at"]], w)
        amplitude = ratio * np.sqrt(band_power(random, dt, w) / (0.5 * np.sum(np.abs(h)**2)))  # N
        phase = rng.uniform(0, 2 * np.pi)
        total += np.real(np.outer(amplitude * h, np.exp(1j * (w * t + phase))))  # steady state
        on = np.abs(w - omega) < zeta * omega
        truth.append({"omega": float(w), "amplitude_n": amplitude, "ratio": ratio,
                      "on_mode": float(omega[on][0]) if on.any() else None})
    sigma = NOISE * np.sqrt(np.mean(random**2, axis=1, keepdims=True))
    noise = sigma * rng.standard_normal(random.shape)
    return {"structure": s, "clean": random + noise, "disturbed": total + noise, "harmonics": truth}


def trace(y: np.ndarray, dt: float, name: str) -> Trace:
    channels = {f"velocity_{i + 1}_w": Channel(f"velocity_{i + 1}_w", row, "velocity", "m/s", i + 1, "w",
                                               np.full(3, np.nan), NOISE) for i, row in enumerate(y)}
    return Trace(Path(f"{name}.h5"), np.arange(y.shape[1]) * dt, dt, dt, channels, {},
                 {"test": name, "repetition": 0, "structure": name}, {"kind": "random"})


def run(kind: str, seed: int, uncertainty: str = "jackknife") -> dict:
    c = case(kind, seed)
    s = c["structure"]
    truth = {"omega": s["omega"].tolist(), "zeta": s["zeta"].tolist(), "harmonics": c["harmonics"],
             "sensor_dofs": [[i + 1, "w"] for i in range(s["shapes"].shape[0])],
             "mode_shapes": s["shapes"].tolist()}
    out = {"seed": seed, "harmonics": c["harmonics"]}
    for label in ("clean", "disturbed"):
        start = time.perf_counter()
        try:
            run_ = modal.identify([trace(c[label], s["dt"], f"{kind}-{seed}")], uncertainty=uncertainty).to_dict()
        except IdentificationError as err:
            out[label] = {"error": str(err)}
            continue
        scores = modal_scores(run_, truth)
        out[label] = scores | {"seconds": time.perf_counter() - start,
                               "harmonic": harmonic_scores(run_, truth["harmonics"], truth)}
    return out


def _pct(values: list[float]) -> str:
    a = np.asarray(values, dtype=float)
    a = a[np.isfinite(a)]
    if not a.size:
        return "n/a"
    return f"median {np.median(a):.3g}, 10-90 % {np.percentile(a, 10):.3g} .. {np.percentile(a, 90):.3g}"


def summary(rows: list[dict]) -> str:
    ok = [r for r in rows if "error" not in r["disturbed"] and "error" not in r["clean"]]
    h = [r["disturbed"]["harmonic"] for r in ok]
    listed = sum(x["listed"] for x in h)
    total = sum(x["harmonics"] for x in h)
    on = [(t, lst) for r in ok for t, lst in zip(r["harmonics"], r["disturbed"]["harmonic"]["listed_each"])
          if t["on_mode"] is not None]
    lines = [f"cases: {len(rows)} ({len(rows) - len(ok)} failed)",
             f"harmonics listed: {listed} of {total} ({100 * listed / max(total, 1):.1f} %); "
             f"on a mode: {sum(lst for _, lst in on)} of {len(on)}",
             f"harmonics reported as modes: {sum(x['as_modes'] for x in h)} (cases: "
             f"{sum(x['as_modes'] > 0 for x in h)}); clean records: "
             f"{sum(r['clean']['harmonic']['as_modes'] for r in ok)}",
             f"modes listed as harmonics: {sum(x['modes_as_harmonics'] for x in h)} (clean records: "
             f"{sum(r['clean']['harmonic']['listed_spurious'] for r in ok)} spurious harmonics listed)"]
    for label in ("clean", "disturbed"):
        fe = [abs(e) for r in ok for e in r[label]["freq_error_pct"]]
        de = [abs(e) for r in ok for e in r[label]["damping_error_pct"]]
        found = np.mean([np.isfinite(w) for r in ok for w in r[label]["omega"]])
        lines.append(f"{label}: modes found {100 * found:.1f} %; |freq error| % {_pct(fe)}; "
                     f"|damping error| % {_pct(de)}; seconds {_pct([r[label]['seconds'] for r in ok])}")
    # per mode, the change the harmonics make to the error
    d = [abs(a) - abs(b) for r in ok for a, b in zip(r["disturbed"]["freq_error_pct"], r["clean"]["freq_error_pct"])]
    lines.append(f"|freq error| with minus without harmonics, % points: {_pct(d)}; largest "
                 f"{np.nanmax(np.abs(d)) if d else float('nan'):.3g}")
    dz = [abs(a) - abs(b) for r in ok
          for a, b in zip(r["disturbed"]["damping_error_pct"], r["clean"]["damping_error_pct"])]
    lines.append(f"|damping error| with minus without, % points: {_pct(dz)}")
    return "\n".join(lines)


def _plain(value: object) -> object:
    """JSON form of numpy scalars and arrays in a row."""
    return value.tolist() if isinstance(value, (np.ndarray, np.generic)) else str(value)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--structure", choices=("beam", "ch3", "frame"), default="beam")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first", type=int, default=1000)
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--uncertainty", choices=("jackknife", "off"), default="jackknife",
                    help="the modal method's option (off: about half the time, no standard errors)")
    ap.add_argument("--save", type=Path, help="append each case's row to this JSON-lines file as it ends")
    ap.add_argument("--summarise", type=Path, nargs="+", metavar="FILE",
                    help="print the summary of rows saved by --save (runs nothing)")
    args = ap.parse_args(argv)
    if args.summarise:
        rows = [json.loads(line) for f in args.summarise for line in f.read_text().splitlines() if line.strip()]
        seeds = sorted(r["seed"] for r in rows)
        print(f"{len(rows)} saved rows, seeds {seeds[0]}-{seeds[-1]}" if rows else "no rows")
        print(summary(rows))
        return
    rows = []
    for seed in range(args.first, args.first + args.seeds):
        row = run(args.structure, seed, args.uncertainty)
        rows.append(row)
        if args.save:
            with args.save.open("a") as fh:
                fh.write(json.dumps(row, default=_plain) + "\n")
        if args.verbose:
            d = row["disturbed"]
            truth = [(round(t["omega"], 3), round(t["ratio"], 2), t["on_mode"] is not None) for t in row["harmonics"]]
            print(seed, truth, d.get("harmonic", d.get("error")), flush=True)
    print(f"{args.structure}, seeds {args.first}-{args.first + args.seeds - 1}, uncertainty {args.uncertainty}")
    print(summary(rows))


if __name__ == "__main__":
    main()
