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
modes 1-10). Prints per case the median over seeds of the worst frequency
error of modes 1-10 (%), of the worst damping error (% of the truth; damped
case), and the median wall and CPU time per identification; then the time
ratios (peer / structbench) of the medians. Both run in this process, one
after the other on the same traces; the peer's BLAS is held to one thread
(``--peer-threads``): OpenBLAS's threads spin when the cores are shared, and
on a loaded machine made pyoma-2's SVD up to 40 times slower, which would
flatter the ratio. The modal method runs its BLAS on one thread and its
jackknife replicates on two.

    python benchmarks/modal_peers.py [--seeds 5] [--br 100] [--ordmax 40] [--peer-threads 1] [--block-rows P]
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from modal_accuracy import beam_case, damped_case  # noqa: E402

from threadpoolctl import threadpool_limits  # noqa: E402

from structbench.identifier import modal  # noqa: E402

ETA = 0.005  # 1/s, artificial damping for the peer on undamped data
logging.disable(logging.INFO)  # pyoma-2 logs every step
os.environ.setdefault("TQDM_DISABLE", "1")


def peer(y: np.ndarray, dt: float, true_omega: np.ndarray, br: int, ordmax: int, undamped: bool
         ) -> tuple[np.ndarray, np.ndarray]:
    """pyoma-2 SSI-cov on outputs ``y`` (n, m): omega (rad/s) and zeta at the true modes (NaN if not found)."""
    from pyoma2.algorithms import SSI
    from pyoma2.setup import SingleSetup

    t = np.arange(y.shape[0]) * dt
    data = y * np.exp(-ETA * t)[:, None] if undamped else y
    setup = SingleSetup(data, fs=1.0 / dt)
    alg = SSI(name="ssicov", method="cov", br=br, ordmax=ordmax)
    setup.add_algorithms(alg)
    setup.run_by_name("ssicov")
    try:
        setup.mpe("ssicov", sel_freq=list(true_omega / (2 * np.pi)), order_in="find_min", rtol=0.01)
    except Exception:  # noqa: BLE001 - a mode the peer cannot find
        return np.full(true_omega.size, np.nan), np.full(true_omega.size, np.nan)
    w, z = 2 * np.pi * np.asarray(alg.result.Fn, dtype=float), np.asarray(alg.result.Xi, dtype=float)
    if undamped:
        sigma = z * w - ETA
        wd = w * np.sqrt(1 - z**2)
        w = np.sqrt(wd**2 + sigma**2)
        z = sigma / w
    return w, z


def ours(traces, model, true_omega: np.ndarray, block_rows: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    result = modal.identify(traces, model, block_rows=block_rows)
    w, z = np.array(result.omega), np.array(result.damping)
    idx = [int(np.argmin(np.abs(w - e))) if w.size else -1 for e in true_omega]
    ok = np.array([i >= 0 and abs(w[i] - e) < 0.05 * e for i, e in zip(idx, true_omega)])
    return np.where(ok, w[idx], np.nan), np.where(ok, z[idx], np.nan)


def run(name: str, seeds: int, br: int, ordmax: int, peer_threads: int, block_rows: int | None) -> None:
    rows = {"structbench modal": [], "pyoma-2 SSI-cov": []}
    for seed in range(seeds):
        traces, model = beam_case(seed) if name == "beam" else damped_case(seed, "impulse")
        true_w, true_z = model.omega[:10], model.zeta[:10]
        y = np.column_stack([c.data for c in traces[0].channels.values()])
        for label, call in (("structbench modal", lambda: ours(traces, model, true_w, block_rows)),
                            ("pyoma-2 SSI-cov", lambda: peer(y, traces[0].dt, true_w, br, ordmax,
                                                             name == "beam"))):
            with threadpool_limits(peer_threads if label.startswith("pyoma") else None):
                t0, c0 = time.perf_counter(), time.process_time()
                w, z = call()
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            f_err = np.abs(100 * (w[:10] - true_w) / true_w)
            z_err = np.abs(100 * (z[:10] - true_z) / true_z) if np.all(true_z > 0) else np.full(10, np.nan)
            rows[label].append((np.max(f_err), np.max(z_err), wall, cpu))
    print(f"\n== {name}: {seeds} seeds, modes 1-10, 2 % noise; structbench block rows "
          f"{block_rows or 'automatic'}; pyoma-2 br = {br}, ordmax = {ordmax}, {peer_threads} BLAS thread(s)")
    print(f" {'method':20s} worst freq err % (median [max])   worst damping err % (median)   "
          "wall s / CPU s (medians)")
    medians = {}
    for label, values in rows.items():
        a = np.array(values)
        medians[label] = np.median(a[:, 2:], axis=0)
        print(f" {label:20s} {np.median(a[:, 0]):10.4f} [{np.max(a[:, 0]):.4f}]"
              f"          {np.median(a[:, 1]):10.3f}                {medians[label][0]:8.3f} / {medians[label][1]:.3f}")
    ratio = medians["pyoma-2 SSI-cov"] / medians["structbench modal"]
    print(f" time ratio peer / structbench: wall {ratio[0]:.1f}, CPU {ratio[1]:.1f}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--br", type=int, default=100, help="pyoma-2 block rows")
    parser.add_argument("--ordmax", type=int, default=40, help="pyoma-2 highest model order")
    parser.add_argument("--peer-threads", type=int, default=1, help="pyoma-2's BLAS threads")
    parser.add_argument("--block-rows", type=int, help="the modal method's block rows (default automatic)")
    parser.add_argument("--case", action="append", choices=["beam", "damped-impulse"])
    args = parser.parse_args(argv)
    for name in args.case or ["beam", "damped-impulse"]:
        run(name, args.seeds, args.br, args.ordmax, args.peer_threads, args.block_rows)


if __name__ == "__main__":
    main()
