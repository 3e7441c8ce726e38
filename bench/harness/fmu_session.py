"""Drive one FMU instance with fmpy: set parameters, run force histories, reset.

Sampling convention of :meth:`FmuSession.run`, for ``k = 0 .. n-1`` and
``t_k = start_time + k dt``: set the inputs to ``forces[k]``, read the outputs
at ``t_k`` (so direct-feedthrough outputs such as acceleration see
``forces[k]``), then ``doStep(t_k, dt)`` with ``forces[k]`` held.

FMI 2.0 co-simulation FMUs run through a tight loop of ctypes calls
(``fmi2SetReal``/``fmi2GetReal``/``fmi2DoStep`` on preallocated buffers;
``fmi2SetReal`` only when ``forces[k]`` differs from ``forces[k - 1]``, since
an FMU keeps its inputs until they are set again);
FMI 3.0 co-simulation through fmpy's ``FMU3Slave``; model exchange through
``fmpy.simulate_fmu`` (CVode) with a zero-order-hold input table. An FMU that
offers both runs as co-simulation unless ``interface="model-exchange"``;
``substeps`` splits each co-simulation step into that many ``doStep`` calls
with the inputs held. FMU logging is on
and every message is forwarded to ``log``; a call returning discard, error or
fatal raises :class:`FmuError` carrying the FMU's error messages.
"""
from __future__ import annotations

import contextlib
import hashlib
import shutil
import sys
from collections import deque
from pathlib import Path
from typing import Callable, Mapping, NamedTuple, Sequence

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException

from structbench.models.errors import UserError

from .fmi_backends import Backend, Fmi2CoSimulation, Fmi3CoSimulation, ModelExchange

STATUS = ["ok", "warning", "discard", "error", "fatal", "pending"]


class FmuError(UserError):
    """An FMU call failed; ``messages`` are the FMU's warning and error log lines."""

    def __init__(self, message: str, messages: Sequence[str] = (), field: str | None = None):
        self.messages = list(messages)
        detail = "; ".join(self.messages)
        super().__init__(f"{message}: {detail}" if detail else message, field=field)


class VariableInfo(NamedTuple):
    """A model variable as read from modelDescription.xml (unit: SI name, or None)."""

    value_reference: int
    causality: str
    variability: str
    unit: str | None
    description: str | None


def fmu_checksum(path: str | Path) -> str:
    """sha256 of the FMU file, hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


class FmuSession:
    """One instance of an FMU, reused across runs.

    A run starts fresh after construction or :meth:`reset` and otherwise
    continues the previous run (``start_time`` must then be where it ended).
    Parameters given to :meth:`set_parameters` persist across resets.
    """

    def __init__(self, path: str | Path, instance_name: str = "structbench",
                 log: Callable[[str], None] | None = None, interface: str | None = None,
                 relative_tolerance: float = 1e-10):
        """``interface``: ``"co-simulation"``, ``"model-exchange"`` or None (co-simulation
        when offered); ``relative_tolerance``: CVode's, for model exchange.
        Raises :class:`UserError` when the FMU does not offer the interface."""
        self.path = Path(path)
        self.interface = interface
        self.relative_tolerance = relative_tolerance
        if not self.path.is_file():
            raise UserError("no such FMU file", field=str(path))
        self.instance_name = instance_name
        self._log = log
        self._messages: deque[tuple[int, str]] = deque(maxlen=20)  # (status, text), status >= warning
        try:
            self.model_description = read_model_description(str(self.path), validate=False)
        except Exception as err:  # fmpy raises plain Exceptions for unreadable files
            raise UserError(f"not a readable FMU: {err}", field=str(path)) from None
        md = self.model_description
        self.variables: dict[str, VariableInfo] = {
            v.name: VariableInfo(v.valueReference, v.causality, v.variability, v.unit, v.description)
            for v in md.modelVariables}
        self._types = {v.name: v.type for v in md.modelVariables}
        self._params: dict[str, float] = {}
        self._state = "instantiated"  # -> running -> (reset) instantiated; failed | fatal
        self._time = 0.0
        self._sys_path = list(sys.path)
        self._unzipdir: str | None = str(extract(str(self.path)))
        try:
            self._backend = self._new_backend()
            self.call("instantiate", self._backend.instantiate)
        except BaseException:
            self._cleanup()
            raise

    def _new_backend(self) -> Backend:
        """The backend of this FMU's FMI flavour (loads its shared library)."""
        md = self.model_description
        if self.interface not in (None, "co-simulation", "model-exchange"):
            raise UserError(f"unknown interface {self.interface!r}", field="interface")
        wanted = {"co-simulation": md.coSimulation, "model-exchange": md.modelExchange}.get(self.interface, True)
        if wanted is None:
            raise UserError(f"the FMU offers no {self.interface}", field=self.path.name)
        if self.interface != "model-exchange" and md.coSimulation is not None:
            if md.fmiVersion == "2.0":
                return Fmi2CoSimulation(self)
            if md.fmiVersion.startswith("3."):
                return Fmi3CoSimulation(self)
        if md.modelExchange is not None:
            return ModelExchange(self, self.relative_tolerance)
        raise UserError(f"unsupported FMU: FMI {md.fmiVersion} without co-simulation or model exchange",
                        field=self.path.name)

    # ---- logging and errors ------------------------------------------------
    def on_log(self, status: int, message: str) -> None:
        """Called by the FMU's logger callback: forward, and keep warnings and errors."""
        label = STATUS[status] if 0 <= status < len(STATUS) else str(status)
        if status >= 1:
            self._messages.append((status, f"[{label}] {message}"))
        if self._log is not None:
            self._log(f"[{label}] {self.instance_name}: {message}")

    def error(self, what: str, status: int | None = None, t: float | None = None,
              fail: bool = True) -> FmuError:
        """An :class:`FmuError` with the messages logged so far; ``fail`` marks
        the instance as needing :meth:`reset`."""
        if fail:
            self._state = "fatal" if status == 4 else "failed"
        label = f" ({STATUS[status]})" if status is not None and 0 <= status < len(STATUS) else ""
        when = f" at t = {t:.9g} s" if t is not None else ""
        messages = [text for _, text in self._messages]
        self._messages.clear()
        return FmuError(f"{what} failed{label}{when}", messages, field=self.path.name)

    def call(self, what: str, fn: Callable, *args, t: float | None = None):
        """Call an fmpy wrapper, turning its exceptions into :class:`FmuError`."""
        try:
            return fn(*args)
        except (FmuError, UserError):
            raise
        except FMICallException as err:
            raise self.error(err.function, err.status, t) from None
        except Exception as err:
            raise self.error(f"{what} ({err})", None, t) from None

    def check_log(self, what: str, fail: bool = True) -> None:
        """Raise if the FMU logged an error although its calls returned ok."""
        if any(status >= 3 for status, _ in self._messages):
            raise self.error(what, fail=fail)
        self._messages.clear()

    # ---- variables ---------------------------------------------------------
    def value_references(self, names: Sequence[str], causalities: tuple[str, ...], role: str) -> list[int]:
        """Value references of real variables ``names`` whose causality is allowed."""
        refs = []
        for name in names:
            info = self.variables.get(name)
            if info is None:
                raise UserError(f"no variable {name!r} in {self.path.name}", field=role)
            if self._types[name] not in {"Real", "Float64"} or info.causality not in causalities:
                raise UserError(f"{name} is a {self._types[name]} {info.causality}, expected a real "
                                f"{' or '.join(causalities)}", field=role)
            refs.append(info.value_reference)
        return refs

    # ---- public API ----------------------------------------------------------
    def set_parameters(self, values: Mapping[str, float]) -> None:
        """Set parameters (by name, SI units); they persist across :meth:`reset`.

        Applied at once (tunable ones also during a run); fixed ones cannot
        change during a run: call :meth:`reset` first.
        """
        names = list(values)
        refs = self.value_references(names, ("parameter",), "parameters")
        if self._state == "running":
            fixed = [n for n in names if self.variables[n].variability != "tunable"]
            if fixed:
                raise UserError(f"{', '.join(fixed)} cannot change during a run: call reset() first",
                                field="parameters")
        floats = [float(values[n]) for n in names]
        self._params.update(zip(names, floats))
        if self._state in ("instantiated", "running"):
            self.call("set parameters", self._backend.set_reals, refs, floats)
            self.check_log("set parameters", fail=False)

    def apply_parameters(self) -> None:
        """Set every stored parameter (at the start of a fresh run)."""
        if self._params:
            refs = self.value_references(list(self._params), ("parameter",), "parameters")
            self.call("set parameters", self._backend.set_reals, refs, list(self._params.values()))
            self.check_log("set parameters")

    def reset(self) -> None:
        """Return to the state after instantiation (parameters are re-applied at the next run)."""
        if self._state == "instantiated":
            return
        if self._state == "fatal":  # a new instance, library reloaded (fmpy unloads it on free)
            self.call("free instance", self._backend.free)
            self._backend = self._new_backend()
            self.call("instantiate", self._backend.instantiate)
        else:
            self.call("reset", self._backend.reset)
        self._messages.clear()
        self._state = "instantiated"

    def run(self, inputs: Sequence[str], outputs: Sequence[str], forces: np.ndarray, dt: float,
            start_time: float = 0.0, substeps: int = 1) -> np.ndarray:
        """Response to a force history.

        ``forces`` has shape (n_steps, len(inputs)) in the inputs' units, held
        over each step of ``dt`` s; returns shape (n_steps, len(outputs)),
        row k sampled at ``t_k = start_time + k dt`` with ``forces[k]`` applied.
        ``substeps``: co-simulation ``doStep`` calls of ``dt / substeps`` s per
        step (model exchange: ignored, CVode chooses its steps).
        """
        if not (isinstance(substeps, (int, np.integer)) and substeps >= 1):
            raise UserError(f"substeps must be a positive integer, got {substeps!r}", field="substeps")
        forces = np.ascontiguousarray(forces, dtype=np.float64)
        if forces.ndim != 2 or forces.shape[1] != len(inputs):
            raise UserError(f"forces must have shape (n_steps, {len(inputs)}), got {forces.shape}",
                            field="forces")
        if not (dt > 0 and np.isfinite(dt)):
            raise UserError(f"step must be positive, got {dt}", field="dt")
        in_refs = self.value_references(inputs, ("input",), "inputs")
        out_refs = self.value_references(outputs, ("output", "local", "parameter", "calculatedParameter"),
                                         "outputs")
        if self._state in ("failed", "fatal"):
            raise UserError("the previous run failed: call reset() first", field=self.path.name)
        if self._state == "running" and not np.isclose(start_time, self._time, rtol=1e-12, atol=1e-9 * dt):
            raise UserError(f"the previous run ended at t = {self._time:.9g} s; continue from there "
                            "or call reset() to start again", field="start_time")
        out = np.empty((forces.shape[0], len(outputs)))
        if self._state == "instantiated":
            self._state = "running"
            self._backend.start(start_time)
            self.check_log("initialization")
        self._backend.loop(in_refs, out_refs, forces, dt, start_time, out, int(substeps))
        self._time = start_time + forces.shape[0] * dt
        self.check_log("run")
        return out

    def close(self) -> None:
        """Free the instance and delete the extracted files."""
        if self._unzipdir is None:
            return
        try:
            if self._state == "running":
                with contextlib.suppress(Exception):
                    self._backend.terminate()
            self._backend.free()
        finally:
            self._cleanup()

    def _cleanup(self) -> None:
        # pythonfmu prepends the FMU's resources folder to sys.path: undo that
        sys.path[:] = [p for p in sys.path if p in self._sys_path or not p.startswith(self._unzipdir)]
        shutil.rmtree(self._unzipdir, ignore_errors=True)
        self._unzipdir = None

    def __enter__(self) -> "FmuSession":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def unzipdir(self) -> str:
        return str(self._unzipdir)

    @property
    def parameters(self) -> dict[str, float]:
        """The parameters set so far (applied at every fresh start)."""
        return dict(self._params)
