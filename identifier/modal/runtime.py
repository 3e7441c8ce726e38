"""Opt-in process tuning for many small factorisations and FFTs.

Off by default: an identification changes nothing outside its own work.
A process that runs identifications and nothing else (a benchmark, a
worker) may opt in, by calling :func:`tune_process` or by setting the
environment variable ``STRUCTBENCH_TUNE_PROCESS=1`` before its first
identification. Tuning then does three things, for the whole process and
for good:

- glibc's mmap and trim thresholds are raised to :data:`MMAP_THRESHOLD` and
  :data:`TRIM_THRESHOLD`, so the few-MB arrays an SSI-cov identification
  allocates and frees over and over stay in the heap instead of being
  faulted in again page by page (no effect where the C library has no
  ``mallopt``);
- BLAS runs on one thread inside :func:`one_blas_thread` (threads only cost
  on matrices of tens to a few thousand rows); threadpoolctl's limit is
  process-wide, so this is not safe for identifications run in threads;
- every FFT of the modal method first clears the AVX registers' upper
  halves (:func:`clear_upper_registers`), against OpenBLAS's AVX-512
  complex kernels that return without ``vzeroupper`` and slow SSE code run
  after them (docs/openblas-dirty-avx.md has a minimal reproducer).

What each is worth is measured by ``benchmarks/fft_registers.py`` and
``tests/test_runtime.py``.
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
from functools import cache

import numpy as np
import scipy.fft as sfft
from threadpoolctl import ThreadpoolController

ENVIRONMENT = "STRUCTBENCH_TUNE_PROCESS"
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc <malloc.h>
MMAP_THRESHOLD = 32 << 20  # bytes: blocks below this come from the heap
TRIM_THRESHOLD = 64 << 20  # bytes: free memory at the top of the heap kept up to this
_SCRATCH = np.zeros(64)  # numpy's AVX loops run from 16 elements on (and end with vzeroupper)
_tuned = False


def tuned() -> bool:
    """Whether this process opted in (:func:`tune_process` was called, or the
    environment variable ``STRUCTBENCH_TUNE_PROCESS`` is ``1``)."""
    return _tuned or os.environ.get(ENVIRONMENT, "") == "1"


def tune_process() -> bool:
    """Opt this process in (irreversible); True when glibc took the malloc
    thresholds, False where the C library has no ``mallopt``."""
    global _tuned
    _tuned = True
    return keep_freed_memory()


@cache
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def one_blas_thread() -> contextlib.AbstractContextManager:
    """Context manager: inside it BLAS runs on one thread when the process is
    tuned; otherwise it changes nothing."""
    return _controller().limit(limits=1, user_api="blas") if tuned() else contextlib.nullcontext()


@cache
def keep_freed_memory() -> bool:
    """Set glibc's mmap and trim thresholds (once per process); False where
    the C library has no ``mallopt`` (macOS) or refuses the values."""
    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))


def tune_from_environment() -> None:
    """Apply the malloc thresholds when the environment opts in (called at
    the start of an identification)."""
    if tuned():
        keep_freed_memory()


def clear_upper_registers() -> None:
    """Leave the AVX registers' upper halves zero (a 64-element numpy
    ufunc: its AVX loop ends with ``vzeroupper``)."""
    np.multiply(_SCRATCH, 0.0, out=_SCRATCH)


def rfft(x: np.ndarray, n: int | None = None, axis: int = -1) -> np.ndarray:
    """``scipy.fft.rfft``, on cleared vector registers when the process is tuned."""
    if tuned():
        clear_upper_registers()
    return sfft.rfft(x, n=n, axis=axis)


def irfft(x: np.ndarray, n: int, axis: int = -1) -> np.ndarray:
    """``scipy.fft.irfft``, on cleared vector registers when the process is tuned."""
    if tuned():
        clear_upper_registers()
    return sfft.irfft(x, n=n, axis=axis)
