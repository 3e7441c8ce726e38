"""BLAS threads for many small factorisations, where threads only cost.

``threadpoolctl.threadpool_limits`` looks up the loaded BLAS libraries on
every call (about 1.4 ms, a tenth of a fast identification); the
controller here looks them up once per process.
"""
from __future__ import annotations

from functools import cache

from threadpoolctl import ThreadpoolController


@cache
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def one_blas_thread():
    """Context manager: BLAS calls inside run on one thread."""
    return _controller().limit(limits=1, user_api="blas")
