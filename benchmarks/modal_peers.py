"""The modal method beside an established package's SSI-cov, on the same
traces, measured in one run like for like: accuracy, wall and CPU time side
by side.

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
truth; damped case), the median wall and CPU time per identification, their
ratio (CPU / wall: how many cores a call kept busy) and the most threads
that ran Python code at once in a call (the caller's included).

Three comparisons:
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
80, is for structures it knows nothing of).

Like for like: both run in this process, one after the other on the same
traces, under the same conditions, which the header prints:
- the same cores: the process (every thread of it, the BLAS libraries'
  idle workers included) is pinned with ``os.sched_setaffinity`` to the
  first ``--cores`` (default 1) of the cores it may use;
- the same BLAS/OpenMP thread limit, as many threads as cores
  (threadpoolctl's ``threadpool_limits`` around the whole run and around
  every call, untimed ones included; process-wide, so also for threads a
  method starts);
- the same process tuning: off unless ``--tune-process`` (or
  ``STRUCTBENCH_TUNE_PROCESS=1``) opts the process in
  (``identifier/modal/runtime.py``; it then raises glibc's malloc
  thresholds for both methods, and the modal method also runs its SSI's BLAS
  on one thread inside the limit and clears the vector registers before
  its FFTs).
The modal method's jackknife (``identifier/modal/uncertainty.py``) sizes its
own thread pool and takes no parameter for it: its threads share the pinned
cores, and the CPU / wall and threads columns show what each call used.
With more threads than free cores (``--cores N`` on a machine busy with
other work) OpenBLAS's threads spin and slow pyoma-2's SVD many times over:
take figures on a quiet machine.
Before the timed calls on a seed's traces, each method identifies them once
untimed. The modal method keeps the spectrum of its subspace iteration's
random probe per Hankel shape (``identifier/modal/ssi/hankel.py``): a
setting's timed calls after its first seed reuse it, as the runs of a
campaign folder do; the medians over seeds are such calls.

    python benchmarks/modal_peers.py [--cores 1] [--seeds 5] [--br 100] [--ordmax 40] [--with-uncertainty]
        [--sweep] [--tune-process]
"""
from __future__ import annotations

import argparse
import logging
import os
import platform
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from modal_accuracy import beam_case, damped_case  # noqa: E402

from threadpoolctl import threadpool_info, threadpool_limits  # noqa: E402

from structbench.identifier import modal  # noqa: E402
from structbench.identifier.modal import runtime  # noqa: E402

ETA = 0.005  # 1/s, artificial damping for the peer on undamped data
OURS, PEER = "structbench modal", "pyoma-2 SSI-cov"
REPO = Path(__file__).resolve().parents[1]
logging.disable(logging.INFO)  # pyoma-2 logs every step
os.environ.setdefault("TQDM_DISABLE", "1")
Setting = tuple[str, str, int | None]  # method, variant ("errors" / "point"), block rows (None: automatic)
COLUMNS = ("freq", "damping", "wall", "cpu", "threads")  # the rows of measure()


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


# --- like-for-like conditions -------------------------------------------------------------------

def pin(cores: int) -> list[int] | None:
    """Pin every thread of this process (threads started later inherit it) to
    the first ``cores`` of the cores it may use; the cores, or None where
    the system has no ``sched_setaffinity``."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    allowed = sorted(os.sched_getaffinity(0))
    if not 1 <= cores <= len(allowed):
        raise SystemExit(f"--cores: {cores} asked, this process may use {len(allowed)} ({_ranges(allowed)})")
    chosen = allowed[:cores]
    tasks = Path("/proc/self/task")
    for tid in (int(t.name) for t in tasks.iterdir()) if tasks.is_dir() else ():
        try:  # the BLAS libraries' worker threads, started when they were loaded
            os.sched_setaffinity(tid, chosen)
        except (ProcessLookupError, PermissionError):
            pass
    os.sched_setaffinity(0, chosen)
    return chosen


def _ranges(cores: list[int]) -> str:
    return ",".join(map(str, cores))


def threads_on(cores: list[int]) -> str:
    """How many of this process's threads are allowed on exactly ``cores`` (Linux: /proc/self/task)."""
    tasks = Path("/proc/self/task")
    if not tasks.is_dir():
        return "threads not listed here"
    ids = [int(t.name) for t in tasks.iterdir()]
    on = 0
    for tid in ids:
        try:
            on += sorted(os.sched_getaffinity(tid)) == cores
        except (ProcessLookupError, PermissionError):
            on += 1  # ended meanwhile
    return f"{on} of its {len(ids)} threads on them"


class ThreadCount:
    """Context manager: ``peak``, the most threads that ran Python code at
    once inside it, the caller's included (counted where they start)."""

    def __enter__(self) -> ThreadCount:
        self.peak, started, original = 1, [], threading.Thread.start
        self._original = original

        def start(thread: threading.Thread) -> None:
            original(thread)
            started.append(thread)
            self.peak = max(self.peak, 1 + sum(t.is_alive() for t in started))

        threading.Thread.start = start  # type: ignore[method-assign]
        return self

    def __exit__(self, *exc) -> None:
        threading.Thread.start = self._original  # type: ignore[method-assign]


def _version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "?"


def _source() -> str:
    """The checkout measured: commit, and whether the identifier has uncommitted changes."""
    try:
        head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--", "identifier"],
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "not a git checkout"
    return f"commit {head}" + (" + uncommitted changes in identifier/" if dirty else "")


def tuning(flag: bool) -> str:
    """Which process tuning (identifier/modal/runtime.py) is measured (``flag``: --tune-process)."""
    value = os.environ.get(runtime.ENVIRONMENT)
    env = f"{runtime.ENVIRONMENT}={value}" if value is not None else f"{runtime.ENVIRONMENT} unset"
    if not runtime.tuned():
        return (f"off ({env}; --tune-process or {runtime.ENVIRONMENT}=1 opts in): malloc thresholds, "
                "BLAS threads and FFTs as the libraries leave them, for both")
    return (f"on ({env}{', --tune-process' if flag else ''}): glibc malloc thresholds raised for "
            "both; the modal method runs its SSI's BLAS on one thread and clears the vector registers "
            "before its FFTs")


def header(cores: list[int] | None, threads: int, tuned: bool) -> None:
    """What was measured, and under which conditions."""
    print("modal_peers: the modal method beside pyoma-2's SSI-cov, like for like "
          "(one process, one method after the other on the same traces)")
    if cores is None:
        print(" cores: not pinned (no sched_setaffinity on this system)")
    else:
        print(f" cores: {_ranges(cores)} for both ({len(cores)} of the {os.cpu_count()} here; "
              f"os.sched_setaffinity, {threads_on(cores)})")
    with threadpool_limits(threads):
        pools = ", ".join(f"{p['internal_api']} {p.get('version') or ''} ({Path(p['filepath']).name.split('-')[0]}):"
                          f" {p['num_threads']}" for p in threadpool_info())
    print(f" BLAS/OpenMP threads: at most {threads} for both (threadpool_limits around every call): {pools}")
    print(" the modal method's jackknife: its own thread pool (identifier/modal/uncertainty.py, no parameter "
          "to size it); its threads share the cores above")
    print(f" process tuning (identifier/modal/runtime.py): {tuning(tuned)}")
    print(f" structbench {_version('structbench')} ({_source()}), pyoma-2 {_version('pyoma-2')}, "
          f"numpy {np.__version__}, Python {platform.python_version()}, {platform.machine()}")
    print(" per call: wall and CPU time of the process; CPU / wall = cores kept busy; threads = most threads "
          "running Python code at once (the caller's included; BLAS's own workers within the limit above)")


# --- measurements -------------------------------------------------------------------------------

def measure(call: Callable, threads: int, true_w: np.ndarray, true_z: np.ndarray) -> tuple[float, ...]:
    """Worst frequency error % of modes 1-10 (inf when one is not found),
    worst damping error % (NaN on undamped data), wall s, CPU s (every
    thread of the process) and the peak thread count of one identification
    ``call`` under ``threads`` BLAS/OpenMP threads."""
    with threadpool_limits(threads), ThreadCount() as count:
        t0, c0 = time.perf_counter(), time.process_time()
        w, z = call()
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    f_err = np.abs(100 * (w[:10] - true_w) / true_w)
    z_err = np.abs(100 * (z[:10] - true_z) / true_z) if np.all(true_z > 0) else np.full(10, np.nan)
    return float(np.max(np.nan_to_num(f_err, nan=np.inf))), float(np.max(z_err)), wall, cpu, float(count.peak)


def settings(name: str, seeds: int, chosen: list[Setting], ordmax: int, threads: int
             ) -> dict[Setting, np.ndarray]:
    """Per setting the rows (seeds, 5) of :func:`measure`, every setting on
    the same traces of each seed, after one untimed point estimate by each
    method on them (the first call on new traces pays for touching their
    memory, whichever method comes first); every call under the same
    thread limit."""
    rows: dict[Setting, list] = {}
    for seed in range(seeds):
        traces, model = beam_case(seed) if name == "beam" else damped_case(seed, "impulse")
        true_w, true_z = model.omega[:10], model.zeta[:10]
        y = np.column_stack([c.data for c in traces[0].channels.values()])
        for method in dict.fromkeys(method for method, _, _ in chosen):
            first = next(p for m, _, p in chosen if m == method)
            with threadpool_limits(threads):
                if method == OURS:
                    ours(traces, model, true_w, first, ordmax, False)
                else:
                    peer(y, traces[0].dt, true_w, first, ordmax, name == "beam")
        for method, variant, rows_ in chosen:
            errors = variant == "errors"
            if method == OURS:
                call = lambda: ours(traces, model, true_w, rows_, ordmax, errors)  # noqa: E731
            else:
                call = lambda: peer(y, traces[0].dt, true_w, rows_, ordmax, name == "beam", errors)  # noqa: E731
            rows.setdefault((method, variant, rows_), []).append(measure(call, threads, true_w, true_z))
    return {key: np.array(value) for key, value in rows.items()}


def table(rows: dict[Setting, np.ndarray]) -> dict[Setting, np.ndarray]:
    """Print one line per setting; return the medians (freq err, damping err, wall, CPU, threads)."""
    print(f" {'method':18s} {'variant':7s} {'rows':>5s}   worst freq err % median [max]   "
          "worst damping err % median   wall s / CPU s (medians)   CPU/wall  threads")
    medians = {}
    for (method, variant, p), a in rows.items():
        medians[method, variant, p] = np.median(a, axis=0)
        f, z, wall, cpu, _ = medians[method, variant, p]
        busy = np.median(a[:, 3] / a[:, 2])
        print(f" {method:18s} {variant:7s} {str(p or 'auto'):>5s}   {f:12.4f} [{np.max(a[:, 0]):.4f}]"
              f"          {z:14.3f}             {wall:8.3f} / {cpu:.3f}             {busy:5.2f}"
              f"  {int(np.max(a[:, 4])):4d}")
    return medians


def _ratios(peer_m: np.ndarray, ours_m: np.ndarray, digits: int = 1) -> str:
    return f"wall {peer_m[2] / ours_m[2]:.{digits}f}, CPU {peer_m[3] / ours_m[3]:.{digits}f}"


def compare(name: str, seeds: int, br: int, ordmax: int, threads: int, block_rows: int | None) -> None:
    """Comparison 1: point estimates and the default beside pyoma-2 at ``br``."""
    rows = settings(name, seeds, [(OURS, "errors", block_rows), (OURS, "point", block_rows), (PEER, "point", br)],
                    ordmax, threads)
    print(f"\n== {name}: {seeds} seeds, modes 1-10, 2 % noise; pyoma-2 br = {br}; highest order {ordmax} for both; "
          f"{threads} BLAS thread(s) for both")
    m = table(rows)
    peer_m = m[PEER, "point", br]
    print(f" time ratio pyoma-2 / structbench: point estimates {_ratios(peer_m, m[OURS, 'point', block_rows])}; "
          f"structbench with its errors {_ratios(peer_m, m[OURS, 'errors', block_rows])}")


def with_errors(name: str, seeds: int, br: int, ordmax: int, threads: int) -> None:
    """Comparison 2: both with standard errors."""
    rows = settings(name, seeds, [(OURS, "errors", None), (PEER, "errors", br)], ordmax, threads)
    print(f"\n== {name}, with uncertainties: {seeds} seed(s); pyoma-2 calc_unc=True, br = {br}; "
          f"{threads} BLAS thread(s) for both")
    m = table(rows)
    print(f" time ratio pyoma-2 / structbench: {_ratios(m[PEER, 'errors', br], m[OURS, 'errors', None], 0)}")


def sweep(name: str, seeds: int, ours_rows: list[int | None], peer_brs: list[int], ordmax: int,
          threads: int) -> None:
    """Comparison 3: point estimates over block rows; for every setting of
    each method the fastest (wall time) setting of the other that is as
    accurate (median worst frequency error no larger), and the time ratios."""
    chosen = [(OURS, "point", p) for p in ours_rows] + [(PEER, "point", b) for b in peer_brs]
    rows = settings(name, seeds, chosen, ordmax, threads)
    print(f"\n== {name}, equal accuracy: {seeds} seeds, point estimates; highest order {ordmax} for both; "
          f"{threads} BLAS thread(s) for both")
    m = table(rows)
    for this, other in ((PEER, OURS), (OURS, PEER)):
        for (method, _, p), own in m.items():
            err, wall = own[0], own[2]
            if method != this:
                continue
            if not np.isfinite(err):
                print(f" {this} at {p or 'auto'}: misses some of modes 1-10")
                continue
            matches = [(v, q) for (meth, _, q), v in m.items() if meth == other and v[0] <= err]
            if not matches:
                print(f" {this} at {p or 'auto'} ({err:.4f} %): no {other} setting as accurate")
                continue
            best, q = min(matches, key=lambda x: x[0][2])
            peer_m, ours_m = (own, best) if this == PEER else (best, own)
            print(f" {this} at {p or 'auto'} ({err:.4f} %, {wall:.3f} s): fastest {other} as accurate "
                  f"{q or 'auto'} ({best[2]:.3f} s); ratio pyoma-2 / structbench {_ratios(peer_m, ours_m)}")


def _sizes(text: str) -> list[int | None]:
    return [None if v == "auto" else int(v) for v in text.split(",")]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cores", type=int, default=1,
                        help="cores for both methods (the process is pinned to them), and as many BLAS/OpenMP "
                             "threads for both (default 1)")
    parser.add_argument("--tune-process", action="store_true",
                        help="opt the process in to identifier/modal/runtime.py's tuning (default: as "
                             f"{runtime.ENVIRONMENT} says, unset: off)")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--br", type=int, default=100, help="pyoma-2 block rows")
    parser.add_argument("--ordmax", type=int, default=40, help="highest model order, of both methods")
    parser.add_argument("--peer-threads", type=int, help=argparse.SUPPRESS)  # gone: one limit for both
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
    if args.peer_threads is not None:
        parser.error("--peer-threads is gone: both methods get the same thread limit, --cores N")
    try:
        import pyoma2.algorithms  # noqa: F401 - loads its libraries (OpenMP) before the thread limit
        import pyoma2.setup  # noqa: F401
    except ImportError:
        parser.error('pyoma-2 is not installed: pip install -e ".[peers]"')
    if args.tune_process:
        runtime.tune_process()
    cores = pin(args.cores)
    threads = args.cores
    header(cores, threads, args.tune_process)
    with threadpool_limits(threads):
        for name in args.case or ["beam", "damped-impulse"]:
            compare(name, args.seeds, args.br, args.ordmax, threads, args.block_rows)
            if args.with_uncertainty:
                with_errors(name, args.unc_seeds, args.unc_br, args.ordmax, threads)
            if args.sweep:
                sweep(name, args.sweep_seeds, _sizes(args.sweep_rows), [int(v) for v in args.sweep_br.split(",")],
                      args.ordmax, threads)


if __name__ == "__main__":
    main()
