"""Tasks in a child process, optionally with a wall-clock limit: the
workers of the local pool and of Dask workers.

:class:`Child` starts a Python that runs :func:`serve` (:data:`COMMAND`,
with this process's ``sys.path``, :func:`host_path`) with :mod:`subprocess`, not
``multiprocessing``: it never imports the caller's ``__main__`` (a script
without an ``if __name__ == "__main__":`` guard is not run again), changes
no process-wide setting, and also works under a Dask worker, whose threads
cannot be stopped and whose daemonic process cannot have ``multiprocessing``
children. The child receives ``(function, args)`` pickled over a pipe, runs
it and sends back the result, keeping its module state (the warm FMU
instance) between tasks, and exits when the pipe closes. A task over its
limit is stopped by killing the child; a child that dies (an FMU that
crashes its host) is reported with its signal.
"""
from __future__ import annotations

import atexit
import os
import subprocess
import sys
import weakref
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

COMMAND = ("import sys; sys.path[:] = sys.argv[3:]; "
           "from structbench.harness.child import serve; serve(int(sys.argv[1]), int(sys.argv[2]))")
STARTUP_SECONDS = 300.0  # s, limit for the child to import structbench and say it is ready
STOP_SECONDS = 30.0  # s, limit for an idle child to close what it opened and exit
_CHILDREN: weakref.WeakSet[Child] = weakref.WeakSet()  # stopped at exit


def host_path() -> list[str]:
    """This process's ``sys.path`` for a child Python, without the resources
    folders of FMUs open here (a pythonfmu FMU run in-process prepends its
    ``resources/``, which holds a copy of pythonfmu without its binaries: a
    child importing that copy would build FMUs that cannot be loaded)."""
    return [p for p in sys.path if not os.path.isfile(os.path.join(p or ".", "slavemodule.txt"))]


class TimedOut(Exception):
    """The task ran longer than its limit; the child was killed."""


class ChildDied(Exception):
    """The child process died during a task (message: its signal or exit status)."""


class Child:
    """One child process that runs tasks sent to it, one at a time."""

    def __init__(self) -> None:
        to_child, from_parent = os.pipe()
        to_parent, from_child = os.pipe()
        self.process = subprocess.Popen([sys.executable, "-c", COMMAND, str(to_child), str(from_child), *host_path()],
                                        pass_fds=(to_child, from_child), stdin=subprocess.DEVNULL)
        os.close(to_child)
        os.close(from_child)
        self.send = Connection(from_parent, readable=False)
        self.recv = Connection(to_parent, writable=False)
        _CHILDREN.add(self)
        try:
            self._answer(STARTUP_SECONDS)  # "ready", once structbench is imported
        except TimedOut:
            raise ChildDied(f"the worker's child process did not start within {STARTUP_SECONDS:g} s") from None

    @property
    def alive(self) -> bool:
        return self.process.poll() is None

    def call(self, fn: Callable[..., Any], args: tuple[Any, ...], timeout: float | None) -> Any:
        """``fn(*args)`` in the child; raises :class:`TimedOut` after ``timeout``
        s (killing the child; None: no limit), :class:`ChildDied`, or what ``fn`` raised."""
        try:
            self.send.send((fn, args))
        except OSError:
            raise ChildDied(self._death()) from None
        return self._answer(timeout)

    def _answer(self, timeout: float | None) -> Any:
        if not self.recv.poll(timeout):
            self.close()
            raise TimedOut
        try:
            raised, value = self.recv.recv()
        except (EOFError, OSError):
            raise ChildDied(self._death()) from None
        if raised:
            raise value
        return value

    def _death(self) -> str:
        code = self.process.wait()
        self.close()
        return f"crashed with signal {-code}" if code < 0 else f"the worker process exited with status {code}"

    def stop(self) -> None:
        """Let an idle child exit on its own (closing its FMU instances and
        their extracted files); killed after :data:`STOP_SECONDS`."""
        self.send.close()
        try:
            self.process.wait(STOP_SECONDS)
        except subprocess.TimeoutExpired:
            pass
        self.close()

    def close(self) -> None:
        """Stop the child (killed: it may be hung in an FMU)."""
        _CHILDREN.discard(self)
        self.process.kill()
        self.process.wait()
        self.send.close()
        self.recv.close()


def _close_all() -> None:
    for child in list(_CHILDREN):
        child.close()


atexit.register(_close_all)


def serve(read_fd: int, write_fd: int) -> None:
    """The child's loop: answer ``(raised, value)`` for each ``(fn, args)`` until the pipe closes."""
    recv, send = Connection(read_fd, writable=False), Connection(write_fd, readable=False)
    send.send((False, "ready"))
    while True:
        try:
            fn, args = recv.recv()
        except EOFError:
            return
        try:
            answer = (False, fn(*args))
        except Exception as err:  # noqa: BLE001 - handed to the parent (as text: it always pickles)
            answer = (True, RuntimeError(f"{type(err).__name__}: {err}"))
        try:
            send.send(answer)
        except OSError:  # the parent is gone (killed): nobody to answer
            return

