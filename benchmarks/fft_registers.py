"""FFTs after a complex matrix product, with and without the vector
registers cleared (the opt-in tuning of identifier/modal/runtime.py), measured
in one run; the process opts in (``runtime.tune_process()``) first.

OpenBLAS's AVX-512 complex kernels return with the upper halves of the
vector registers dirty; pocketfft's SSE code after them pays the AVX/SSE
transition penalty until some AVX code clears them. Prints the BLAS the
process loaded, then per case the median time (ms) dirty and cleared and
their ratio:
- the beam's Hankel product FFT (irfft of 251 x 10 x 50 complex) after ``S @ X``;
- one whole point estimate of the ch5 beam (75 block rows, orders to 40),
  with :func:`identifier.modal.runtime.clear_upper_registers` made a no-op and as shipped.

    python benchmarks/fft_registers.py [--repeat 30]
"""
from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.fft as sfft
from threadpoolctl import threadpool_info

sys.path.insert(0, str(Path(__file__).parent))
from modal_accuracy import beam_case  # noqa: E402

from structbench.identifier import modal  # noqa: E402
from structbench.identifier.modal import runtime  # noqa: E402


def median_ms(call: Callable[[], object], before: Callable[[], object], repeat: int) -> float:
    """Median wall time (ms) of ``call``, each run right after ``before`` (untimed)."""
    times = []
    for _ in range(repeat):
        before()
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30)
    args = parser.parse_args(argv)
    runtime.tune_process()
    for lib in threadpool_info():
        print(f"{lib['internal_api']} {lib['version']} ({lib['architecture']}): {Path(lib['filepath']).name}")
    rng = np.random.default_rng(0)
    S = rng.standard_normal((251, 10, 10)) + 1j * rng.standard_normal((251, 10, 10))
    X = rng.standard_normal((251, 10, 50)) + 1j * rng.standard_normal((251, 10, 50))
    product = S @ X
    with runtime.one_blas_thread():
        dirty = median_ms(lambda: sfft.irfft(product, n=500, axis=0), lambda: S @ X, args.repeat)
        clean = median_ms(lambda: runtime.irfft(product, n=500, axis=0), lambda: S @ X, args.repeat)
    print(f"irfft (251, 10, 50) -> 500 after S @ X: dirty {dirty:.3f} ms, cleared {clean:.3f} ms, "
          f"ratio {dirty / clean:.2f}")
    traces, model = beam_case(0)

    def identify() -> object:
        return modal.identify(traces, model, block_rows=75, max_order=40, uncertainty="off")

    identify()
    shipped = runtime.clear_upper_registers
    runtime.clear_upper_registers = lambda: None
    try:
        dirty = median_ms(identify, lambda: None, args.repeat)
    finally:
        runtime.clear_upper_registers = shipped
    clean = median_ms(identify, lambda: None, args.repeat)
    print(f"ch5 beam point estimate (75 block rows, orders to 40): dirty {dirty:.1f} ms, cleared {clean:.1f} ms, "
          f"ratio {dirty / clean:.2f}")


if __name__ == "__main__":
    main()
