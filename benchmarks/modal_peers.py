"""The modal method beside an established package's SSI-cov, on the same
traces, measured in one run: accuracy and wall time side by side.

Peer: pyoma-2 (``pip install structbench[peers]``), ``SSI(method="cov")``,
given the true frequencies to pick its modes from (``mpe(sel_freq=...,
order_in="find_min")``): that is help the modal method does not get (it
selects its modes itself). pyoma-2 keeps only poles with 0 < zeta < xi_max, so
on the undamped ch5 beam its input is multiplied by ``exp(-eta t)`` (eta =
0.005 1/s, every pole then has damping) and its poles are corrected back
(``sigma = zeta' omega' - eta``, ``omega = sqrt(omega_d^2 + sigma^2)``).

Cases (2 % noise on every channel; see benchmarks/modal_accuracy.py):
``beam`` (ch5, 10 displacement sensors, 100 s at 0.01 s, modes 1-10) and
``damped-impulse`` (campaigns/ch5-damped.toml, velocities, 1000 s at 0.05 s,
modes 1-10). Per case and setting: the median over seeds of the worst
frequency error of modes 1-10 (%), of the worst damping error (% of the
truth; damped case), and the median wall and CPU time per identification.

Like for like, three comparisons:
1. point estimates (frequencies, damping ratios, shapes): the modal method
   with ``uncertainty="off"`` beside pyoma-2 at ``--br``; and its default
   (with jackknife errors) beside the same;
2. with uncertainties (``--with-uncertainty``): the default beside pyoma-2's
   ``calc_unc=True`` (its perturbation-based standard errors, ``nb`` 50
   blocks) at ``--unc-br``, on the first ``--unc-seeds`` seeds (a minute or
   more per identification);
3. at equal accuracy (``--sweep``): both over their block rows (the modal
   method's point estimates), and for every setting of each the fastest
   setting of the other whose median worst frequency error is no larger.
Both fit models up to the same highest order (``--ordmax``, 40: the 15
modes the beam's response carries need 30; the modal method's own default,
80, is for structures it knows nothing of and costs it 2.2-2.4 times as
long, mostly in the eigenvalue problems of the higher orders). Both run in
this process, one after the other on the same traces; the
peer's BLAS is held to one thread (``--peer-threads``): OpenBLAS's threads
spin when the cores are shared, and on a loaded machine made pyoma-2's SVD up
to 40 times slower, which would flatter the ratio. The modal method runs its
BLAS on one thread and its jackknife replicates on two, and raises glibc's
malloc thresholds in its process (``identifier/runtime.py``): pyoma-2 then
runs under the same settings. Before the timed calls on a seed's traces,
each method identifies them once untimed. The modal method keeps the
spectrum of its subspace iteration's random probe per Hankel shape
(``identifier/ssi_hankel.py``, 2.8 ms of the beam's 28 to make): a setting's
timed calls after its first seed reuse it, as the runs of a campaign
folder do; the medians over seeds are such calls.

    python benchmarks/modal_peers.py [--seeds 5] [--br 100] [--ordmax 40] [--with-uncertainty] [--sweep]
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from modal_accuracy import beam_case, damped_case  # noqa: E402

from threadpoolctl import threadpool_limits  # noqa: E402

from structbench.identifier import modal  # noqa: E402

ETA = 0.005  # 1/s, artificial damping for the peer on undamped data
OURS, PEER = "structbench modal", "pyoma-2 SSI-cov"
logging.disable(logging.INFO)  # pyoma-2 logs every step
os.environ.setdefault("TQDM_DISABLE", "1")
Setting = tuple[str, str, int | None]  # method, variant ("errors" / "point"), block rows (None: automatic)


def peer(y: np.ndarray, dt: float, true_omega: np.ndarray, br: int, ordmax: int, undamped: bool,
         errors: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """pyoma-2 SSI-cov on outputs ``y`` (n, m): omega (rad/s) and zeta at the
    true modes (NaN if not found); ``errors``: with its uncertainty bounds."""
    from pyoma2.algorithms import SSI
    from pyoma2.setup import SingleSetup

    t = np.arange(y.shape[0]) * dt
    data = y * np.exp(-ETA * t)[:, None] if undamped else y
    setup = SingleSetup(data, fs=1.0 / dt)
    alg = SSI(name="ssicov", method="cov", br=br, ordmax=ordmax, calc_unc=errors)
    setup.add_algorithms(alg)
    setup.run_by_name("ssicov")
    try:
        setup.mpe("ssicov", sel_freq=list(true_omega / (2 * np.pi)), order_in="find_min", rtol=0.01)
    except Exception:  # noqa: BLE001 - a mode the peer cannot find
        return np.full(true_omega.size, np.nan), np.full(true_omega.size, np.nan)
    w, z = 2 * np.pi * np.asarray(alg.result.Fn, dtype=float), np.asarray(alg.result.Xi, dtype=float)
    if w.size != true_omega.size:  # some modes not found
        return np.full(true_omega.size, np.nan), np.full(true_omega.size, np.nan)
    if undamped:
        sigma = z * w - ETA
        wd = w * np.sqrt(1 - z**2)
        w = np.sqrt(wd**2 + sigma**2)
        z = sigma / w
    return w, z


def ours(traces, model, true_omega: np.ndarray, block_rows: int | None, max_order: int, errors: bool
         ) -> tuple[np.ndarray, np.ndarray]:
    """The modal method: omega (rad/s) and zeta of the modes nearest the true ones (NaN if none within 5 %)."""
    result = modal.identify(traces, model, block_rows=block_rows, max_order=max_order,
                            uncertainty="jackknife" if errors else "off")
    w, z = np.array(result.omega), np.array(result.damping)
    idx = [int(np.argmin(np.abs(w - e))) if w.size else -1 for e in true_omega]
    ok = np.array([i >= 0 and abs(w[i] - e) < 0.05 * e for i, e in zip(idx, true_omega)])
    return np.where(ok, w[idx], np.nan), np.where(ok, z[idx], np.nan)


def measure(call: Callable, threads: int | None, true_w: np.ndarray, true_z: np.ndarray) -> tuple[float, ...]:
    """Worst frequency error % of modes 1-10 (inf when one is not found),
    worst damping error % (NaN on undamped data), wall s and CPU s of one
    identification ``call``."""
    with threadpool_limits(threads):
        t0, c0 = time.perf_counter(), time.process_time()
        w, z = call()
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    f_err = np.abs(100 * (w[:10] - true_w) / true_w)
    z_err = np.abs(100 * (z[:10] - true_z) / true_z) if np.all(true_z > 0) else np.full(10, np.nan)
    return float(np.max(np.nan_to_num(f_err, nan=np.inf))), float(np.max(z_err)), wall, cpu


def settings(name: str, seeds: int, chosen: list[Setting], ordmax: int, peer_threads: int
             ) -> dict[Setting, np.ndarray]:
    """Per setting the rows (seeds, 4) of :func:`measure`, every setting on
    the same traces of each seed, after one untimed point estimate by each
    method on them (the first call on new traces pays for touching their
    memory, whichever method comes first)."""
    rows: dict[Setting, list] = {}
    for seed in range(seeds):
        traces, model = beam_case(seed) if name == "beam" else damped_case(seed, "impulse")
        true_w, true_z = model.omega[:10], model.zeta[:10]
        y = np.column_stack([c.data for c in traces[0].channels.values()])
        for method in dict.fromkeys(method for method, _, _ in chosen):
            first = next(p for m, _, p in chosen if m == method)
            if method == OURS:
                ours(traces, model, true_w, first, ordmax, False)
            else:
                with threadpool_limits(peer_threads):
                    peer(y, traces[0].dt, true_w, first, ordmax, name == "beam")
        for method, variant, rows_ in chosen:
            errors = variant == "errors"
            if method == OURS:
                call, threads = (lambda: ours(traces, model, true_w, rows_, ordmax, errors)), None
            else:
                call, threads = (lambda: peer(y, traces[0].dt, true_w, rows_, ordmax, name == "beam",
                                              errors)), peer_threads
            rows.setdefault((method, variant, rows_), []).append(measure(call, threads, true_w, true_z))
    return {key: np.array(value) for key, value in rows.items()}


def table(rows: dict[Setting, np.ndarray]) -> dict[Setting, np.ndarray]:
    """Print one line per setting; return the medians (freq err, damping err, wall, CPU)."""
    print(f" {'method':18s} {'variant':7s} {'rows':>5s}   worst freq err % median [max]   "
          "worst damping err % median   wall s / CPU s (medians)")
    medians = {}
    for (method, variant, p), a in rows.items():
        medians[method, variant, p] = np.median(a, axis=0)
        f, z, wall, cpu = medians[method, variant, p]
        print(f" {method:18s} {variant:7s} {str(p or 'auto'):>5s}   {f:12.4f} [{np.max(a[:, 0]):.4f}]"
              f"          {z:14.3f}             {wall:8.3f} / {cpu:.3f}")
    return medians


def compare(name: str, seeds: int, br: int, ordmax: int, peer_threads: int, block_rows: int | None) -> None:
    """Comparison 1: point estimates and the default beside pyoma-2 at ``br``."""
    rows = settings(name, seeds, [(OURS, "errors", block_rows), (OURS, "point", block_rows), (PEER, "point", br)],
                    ordmax, peer_threads)
    print(f"\n== {name}: {seeds} seeds, modes 1-10, 2 % noise; pyoma-2 br = {br}; highest order {ordmax} for both; "
          f"{peer_threads} BLAS thread(s)")
    m = table(rows)
    peer_wall = m[PEER, "point", br][2]
    print(f" wall-time ratio pyoma-2 / structbench: point estimates {peer_wall / m[OURS, 'point', block_rows][2]:.1f}, "
          f"structbench with its errors {peer_wall / m[OURS, 'errors', block_rows][2]:.1f}")


def with_errors(name: str, seeds: int, br: int, ordmax: int, peer_threads: int) -> None:
    """Comparison 2: both with standard errors."""
    rows = settings(name, seeds, [(OURS, "errors", None), (PEER, "errors", br)], ordmax, peer_threads)
    print(f"\n== {name}, with uncertainties: {seeds} seed(s); pyoma-2 calc_unc=True, br = {br}")
    m = table(rows)
    print(f" wall-time ratio pyoma-2 / structbench: {m[PEER, 'errors', br][2] / m[OURS, 'errors', None][2]:.0f}")


def sweep(name: str, seeds: int, ours_rows: list[int | None], peer_brs: list[int], ordmax: int,
          peer_threads: int) -> None:
    """Comparison 3: point estimates over block rows; for every setting of
    each method the fastest setting of the other that is as accurate (median
    worst frequency error no larger), and the wall-time ratio."""
    chosen = [(OURS, "point", p) for p in ours_rows] + [(PEER, "point", b) for b in peer_brs]
    rows = settings(name, seeds, chosen, ordmax, peer_threads)
    print(f"\n== {name}, equal accuracy: {seeds} seeds, point estimates; highest order {ordmax} for both")
    m = table(rows)
    for this, other in ((PEER, OURS), (OURS, PEER)):
        for (method, _, p), (err, _, wall, _) in m.items():
            if method != this:
                continue
            if not np.isfinite(err):
                print(f" {this} at {p or 'auto'}: misses some of modes 1-10")
                continue
            matches = [(w, q) for (meth, _, q), (e, _, w, _) in m.items() if meth == other and e <= err]
            if not matches:
                print(f" {this} at {p or 'auto'} ({err:.4f} %): no {other} setting as accurate")
                continue
            w, q = min(matches, key=lambda x: x[0])
            ratio = wall / w if this == PEER else w / wall
            print(f" {this} at {p or 'auto'} ({err:.4f} %, {wall:.3f} s): fastest {other} as accurate "
                  f"{q or 'auto'} ({w:.3f} s); ratio pyoma-2 / structbench {ratio:.1f}")


def _sizes(text: str) -> list[int | None]:
    return [None if v == "auto" else int(v) for v in text.split(",")]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--br", type=int, default=100, help="pyoma-2 block rows")
    parser.add_argument("--ordmax", type=int, default=40, help="highest model order, of both methods")
    parser.add_argument("--peer-threads", type=int, default=1, help="pyoma-2's BLAS threads")
    parser.add_argument("--block-rows", type=int, help="the modal method's block rows (default automatic)")
    parser.add_argument("--case", action="append", choices=["beam", "damped-impulse"])
    parser.add_argument("--with-uncertainty", action="store_true", help="also compare with standard errors")
    parser.add_argument("--unc-seeds", type=int, default=2)
    parser.add_argument("--unc-br", type=int, default=50, help="pyoma-2 block rows with calc_unc")
    parser.add_argument("--sweep", action="store_true", help="also compare at equal accuracy over block rows")
    parser.add_argument("--sweep-seeds", type=int, default=3)
    parser.add_argument("--sweep-rows", default="auto,50,75,100,150,200", help="the modal method's block rows")
    parser.add_argument("--sweep-br", default="25,50,100,200,300,400", help="pyoma-2's block rows")
    args = parser.parse_args(argv)
    for name in args.case or ["beam", "damped-impulse"]:
        compare(name, args.seeds, args.br, args.ordmax, args.peer_threads, args.block_rows)
        if args.with_uncertainty:
            with_errors(name, args.unc_seeds, args.unc_br, args.ordmax, args.peer_threads)
        if args.sweep:
            sweep(name, args.sweep_seeds, _sizes(args.sweep_rows), [int(v) for v in args.sweep_br.split(",")],
                  args.ordmax, args.peer_threads)


if __name__ == "__main__":
    main()
