"""The FMI flavours behind :class:`~.fmu_session.FmuSession`, one class each:
FMI 2.0 co-simulation (a tight loop of raw ctypes calls on preallocated
buffers), FMI 3.0 co-simulation (fmpy's ``FMU3Slave``) and model exchange
(``fmpy.simulate_fmu`` with a zero-order-hold input table). A backend knows
its session only as a :class:`Host` (this module does not import the
session's, which imports this one).
"""
from __future__ import annotations

import ctypes
from typing import Any, Callable, Mapping, Protocol

import numpy as np
from fmpy import simulate_fmu
from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.fmi3 import FMU3Slave

from structbench.models.errors import UserError


class Host(Protocol):
    """What a backend uses of the session that owns it
    (:class:`~.fmu_session.FmuSession`; named here so that this module does
    not import that one, which imports this)."""

    model_description: Any
    instance_name: str
    variables: Mapping[str, Any]  # name -> VariableInfo (value_reference, ...)

    @property
    def unzipdir(self) -> str: ...
    @property
    def parameters(self) -> dict[str, float]: ...
    def on_log(self, status: int, message: str) -> None: ...
    def call(self, what: str, fn: Callable, *args: Any, t: float | None = None) -> Any: ...
    def error(self, what: str, status: int | None = None, t: float | None = None,
              fail: bool = True) -> Exception: ...
    def apply_parameters(self) -> None: ...


class Backend(Protocol):
    """One FMI flavour behind :class:`~.fmu_session.FmuSession`."""

    def instantiate(self) -> None: ...
    def terminate(self) -> None: ...
    def free(self) -> None: ...
    def reset(self) -> None: ...
    def set_reals(self, refs: list[int], values: list[float]) -> None: ...
    def start(self, start_time: float) -> None: ...
    def loop(self, in_refs: list[int], out_refs: list[int], forces: np.ndarray, dt: float,
             start_time: float, out: np.ndarray, substeps: int = 1) -> None: ...


def _raw(dll: ctypes.CDLL, name: str, *argtypes: type) -> Callable[..., int]:
    """A fresh ctypes handle on an FMI function (fmpy's own handles check status)."""
    fn = dll[name]
    fn.argtypes = argtypes
    fn.restype = ctypes.c_int
    return fn


def changed_rows(forces: np.ndarray) -> list[bool]:
    """Per row of ``forces`` (n_steps, n_inputs): whether it differs bit for
    bit from the row before (the first row always counts as changed). An FMU
    keeps an input's value until it is set again, so only these rows need
    ``fmi2SetReal``: a free response saves a third of the FMU calls (a fifth
    of its time on the pythonfmu structures), with the same results."""
    changed = np.ones(forces.shape[0], dtype=bool)
    if forces.shape[0] > 1 and forces.shape[1]:
        bits = np.ascontiguousarray(forces).view(np.uint64)
        np.any(bits[1:] != bits[:-1], axis=1, out=changed[1:])
    return changed.tolist()


def _decode(message: bytes | None) -> str:
    return (message or b"").decode("utf-8", "replace")


class _Slave:
    """Instantiation and life-cycle calls shared by the co-simulation backends
    (``slave_class``: fmpy's slave class of the FMI version)."""

    slave_class: Any

    def __init__(self, session: Host):
        self.session = session
        md = session.model_description
        self.fmu = self.slave_class(guid=md.guid, unzipDirectory=session.unzipdir,
                                    modelIdentifier=md.coSimulation.modelIdentifier,
                                    instanceName=session.instance_name)

    def terminate(self) -> None:
        self.fmu.terminate()

    def free(self) -> None:
        self.fmu.freeInstance()

    def reset(self) -> None:
        self.fmu.reset()


class Fmi2CoSimulation(_Slave):
    """FMI 2.0 co-simulation: the fast path (ctypes calls on preallocated buffers)."""

    slave_class = FMU2Slave

    def __init__(self, session: Host):
        super().__init__(session)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(
            lambda env, instance, status, category, message: session.on_log(status, _decode(message)))
        # no fmpy logger proxy: it keeps one global logger for all instances
        self.callbacks.allocateMemory = defaultCallbacks.allocateMemory
        self.callbacks.freeMemory = defaultCallbacks.freeMemory
        dll = self.fmu.dll
        vp, size, real = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_double
        self.set_real = _raw(dll, "fmi2SetReal", vp, vp, size, vp)
        self.get_real = _raw(dll, "fmi2GetReal", vp, vp, size, vp)
        self.do_step = _raw(dll, "fmi2DoStep", vp, real, real, ctypes.c_int)

    def instantiate(self) -> None:
        self.fmu.instantiate(callbacks=self.callbacks, loggingOn=True)

    def set_reals(self, refs: list[int], values: list[float]) -> None:
        self.fmu.setReal(refs, values)

    def start(self, start_time: float) -> None:
        s = self.session
        s.call("fmi2SetupExperiment", self.fmu.setupExperiment, None, start_time)
        s.call("fmi2EnterInitializationMode", self.fmu.enterInitializationMode)
        s.apply_parameters()
        s.call("fmi2ExitInitializationMode", self.fmu.exitInitializationMode)

    def loop(self, in_refs: list[int], out_refs: list[int], forces: np.ndarray, dt: float,
             start_time: float, out: np.ndarray, substeps: int = 1) -> None:
        """Row k: set ``forces[k]`` (when changed), read ``out[k]`` at t_k, then
        ``substeps`` doSteps of ``dt / substeps`` s with the inputs held."""
        comp = self.fmu.component
        n_in, n_out = len(in_refs), len(out_refs)
        in_vr = (ctypes.c_uint * max(n_in, 1))(*in_refs)
        out_vr = (ctypes.c_uint * max(n_out, 1))(*out_refs)
        in_vr_p, out_vr_p = ctypes.addressof(in_vr), ctypes.addressof(out_vr)
        f_addr, f_stride = forces.ctypes.data, forces.strides[0]
        y_addr, y_stride = out.ctypes.data, out.strides[0]
        set_real, get_real, do_step = self.set_real, self.get_real, self.do_step
        h = dt / substeps
        for k, changed in enumerate(changed_rows(forces)):
            t = start_time + k * dt
            if changed and (status := set_real(comp, in_vr_p, n_in, f_addr + k * f_stride)) > 1:
                raise self.session.error("fmi2SetReal", status, t)
            if (status := get_real(comp, out_vr_p, n_out, y_addr + k * y_stride)) > 1:
                raise self.session.error("fmi2GetReal", status, t)
            if substeps == 1:
                if (status := do_step(comp, t, dt, 1)) > 1:
                    raise self.session.error("fmi2DoStep", status, t)
                continue
            for j in range(substeps):
                if (status := do_step(comp, t + j * h, h, 1)) > 1:
                    raise self.session.error("fmi2DoStep", status, t + j * h)


class Fmi3CoSimulation(_Slave):
    """FMI 3.0 co-simulation through fmpy's ``FMU3Slave`` (Float64 variables)."""

    slave_class = FMU3Slave

    def _logger(self, env: object, status: int, category: bytes, message: bytes) -> None:
        self.session.on_log(status, _decode(message))

    def instantiate(self) -> None:
        self.fmu.instantiate(loggingOn=True, logMessage=self._logger)

    def set_reals(self, refs: list[int], values: list[float]) -> None:
        self.fmu.setFloat64(refs, values)

    def start(self, start_time: float) -> None:
        s = self.session
        s.call("fmi3EnterInitializationMode", self.fmu.enterInitializationMode, None, start_time)
        s.apply_parameters()
        s.call("fmi3ExitInitializationMode", self.fmu.exitInitializationMode)

    def loop(self, in_refs: list[int], out_refs: list[int], forces: np.ndarray, dt: float,
             start_time: float, out: np.ndarray, substeps: int = 1) -> None:
        s, fmu = self.session, self.fmu
        h = dt / substeps
        for k, row in enumerate(forces.tolist()):
            t = start_time + k * dt
            s.call("fmi3SetFloat64", fmu.setFloat64, in_refs, row, t=t)
            out[k] = s.call("fmi3GetFloat64", fmu.getFloat64, out_refs, t=t)
            for j in range(substeps):
                if s.call("fmi3DoStep", fmu.doStep, t + j * h, h, t=t + j * h)[1]:
                    raise s.error("fmi3DoStep (the FMU requested termination)", None, t + j * h)


class ModelExchange:
    """Model exchange through ``fmpy.simulate_fmu`` (CVode at ``relative_tolerance``,
    absolute tolerance that times each state's nominal); every run starts fresh.
    fmpy steps through the output points in Python: about 0.5 ms per sample
    on a 2-state FMU (a 4 s record at 1 ms: 2 s; 120 s: about a minute),
    against about 1 us per co-simulation ``doStep``."""

    def __init__(self, session: Host, relative_tolerance: float = 1e-10):
        self.session = session
        self.relative_tolerance = relative_tolerance
        self.names = {info.value_reference: name for name, info in session.variables.items()}
        self.fresh = False

    def _logger(self, env: object, instance: bytes, status: int, category: bytes, message: bytes) -> None:
        self.session.on_log(status, _decode(message))

    def instantiate(self) -> None:
        """Nothing to do: simulate_fmu instantiates per run."""

    def terminate(self) -> None:
        """Nothing to do: simulate_fmu terminates per run."""

    def free(self) -> None:
        """Nothing to do: simulate_fmu frees per run."""

    def reset(self) -> None:
        """Nothing to do: simulate_fmu instantiates per run."""

    def set_reals(self, refs: list[int], values: list[float]) -> None:
        """Parameters are passed as start values at the next run."""

    def start(self, start_time: float) -> None:
        self.fresh = True

    def loop(self, in_refs: list[int], out_refs: list[int], forces: np.ndarray, dt: float,
             start_time: float, out: np.ndarray, substeps: int = 1) -> None:
        """The run in one ``simulate_fmu`` call; ``substeps`` is ignored (CVode's own steps)."""
        if not self.fresh:
            raise UserError("a model-exchange FMU cannot continue a run: call reset()", field="start_time")
        self.fresh = False
        n = forces.shape[0]
        inputs = [self.names[r] for r in in_refs]
        edges = start_time + dt * np.arange(n + 1)
        # zero-order hold: each value from t_k to t_k+1, a jump at every t_k
        table = np.zeros(2 * n, dtype=[("time", np.float64)] + [(name, np.float64) for name in inputs])
        table["time"][0::2], table["time"][1::2] = edges[:-1], edges[1:]
        for j, name in enumerate(inputs):
            table[name][0::2] = table[name][1::2] = forces[:, j]
        s = self.session
        result = s.call("simulate_fmu", lambda: simulate_fmu(
            s.unzipdir, model_description=s.model_description, fmi_type="ModelExchange",
            start_time=start_time, stop_time=edges[-2] if n > 1 else start_time + dt,
            output_interval=dt, relative_tolerance=self.relative_tolerance, input=table,
            output=[self.names[r] for r in out_refs], start_values=s.parameters,
            debug_logging=True, logger=self._logger, validate=False))
        times = result["time"]
        # the last sample at each t_k is the one after the input switched to forces[k]
        rows = np.searchsorted(times, edges[:-1] + 1e-9 * dt, side="right") - 1
        if np.any(rows < 0) or np.any(np.abs(times[rows] - edges[:-1]) > 1e-6 * dt):
            raise s.error("simulate_fmu (missing output samples)")
        out[:] = np.column_stack([result[self.names[r]] for r in out_refs])[rows]
