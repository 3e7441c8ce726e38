"""Process settings under which many small factorisations run fast.

- BLAS on one thread (:func:`one_blas_thread`): threads only cost on
  matrices of tens to a few thousand rows. ``threadpoolctl.threadpool_limits``
  looks up the loaded BLAS libraries on every call (about 1.4 ms, a tenth
  of a fast identification); the controller here looks them up once.
- Freed memory kept for reuse (:func:`keep_freed_memory`): glibc hands
  every freed block above 128 kB back to the system, and the next array
  of that size is faulted in again page by page. An SSI-cov identification
  allocates and frees its Hankel products, FFTs and factorisations (each a
  few MB) thousands of times over: 3,000-9,000 page faults per
  identification of the ch5 beam, a quarter of its time on the 2-core
  test machine (about 4 us each). Raising glibc's mmap threshold to 32 MB
  and its trim threshold to 64 MB (what glibc itself adopts after the
  first free of a 32 MB block) keeps them in the heap: no faults.
- FFTs on clean vector registers (:func:`rfft`, :func:`irfft`):
  OpenBLAS's AVX-512 complex kernels (``zgemm``, the ``SkylakeX`` ones,
  which it also picks on AMD Zen 4) return without ``vzeroupper``. Until
  some AVX code executes one, non-VEX SSE code pays a false dependency on
  every instruction (the AVX/SSE transition penalty). Of what the modal
  method runs, only pocketfft's FFTs are such code: after any complex
  matrix product (``S @ X``, a MAC matrix, complex shapes) they ran 2.7
  times slower (1.42 ms instead of 0.53 ms for the beam's Hankel
  products), a seventh of an identification; LAPACK, numpy's random
  numbers and reductions were not slowed. Real products (``dgemm``) and
  numpy's own SIMD loops leave the registers clean, so a 64-element numpy
  ufunc before each FFT (about 1 us) clears them.
"""
from __future__ import annotations

import ctypes
import ctypes.util
from functools import cache

import numpy as np
import scipy.fft as sfft
from threadpoolctl import ThreadpoolController

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc <malloc.h>
MMAP_THRESHOLD = 32 << 20  # bytes: blocks below this come from the heap
TRIM_THRESHOLD = 64 << 20  # bytes: free memory at the top of the heap kept up to this
_SCRATCH = np.zeros(64)  # numpy's AVX loops run from 16 elements on (and end with vzeroupper)


@cache
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def one_blas_thread():
    """Context manager: BLAS calls inside run on one thread."""
    return _controller().limit(limits=1, user_api="blas")


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


def clear_upper_registers() -> None:
    """Leave the AVX registers' upper halves zero (a 64-element numpy
    ufunc: its AVX loop ends with ``vzeroupper``)."""
    np.multiply(_SCRATCH, 0.0, out=_SCRATCH)


def rfft(x: np.ndarray, n: int | None = None, axis: int = -1) -> np.ndarray:
    """``scipy.fft.rfft`` on clean vector registers (see the module docstring)."""
    clear_upper_registers()
    return sfft.rfft(x, n=n, axis=axis)


def irfft(x: np.ndarray, n: int, axis: int = -1) -> np.ndarray:
    """``scipy.fft.irfft`` on clean vector registers (see the module docstring)."""
    clear_upper_registers()
    return sfft.irfft(x, n=n, axis=axis)
