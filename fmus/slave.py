"""pythonfmu co-simulation slave of one structure (template, bundled per FMU).

The builder copies this file into the FMU's resources as ``<module>.py`` next
to ``<module>_rt.py`` (the runtime) and ``<module>.json`` (the spec), with a
module name unique per FMU. It needs numpy, scipy and pythonfmu (bundled),
never structbench.

All real variables live in one buffer indexed by value reference. Outputs are
computed lazily from the state and the current input: ``[u, v, a]`` with
``a = M^-1 (f - C v - K u)`` (modal: ``Phi (Phi^T f - 2 zeta omega qd - omega^2 q)``).
``do_step`` propagates the state exactly (zero-order hold). Invalid values are
logged with status error and make the next ``do_step`` fail (fmi2Discard);
the slave never raises, since pythonfmu turns an exception into fmi2Fatal and
frees the instance.
"""
from __future__ import annotations

import importlib
import json
import math
from pathlib import Path
from typing import Any
from xml.etree.ElementTree import Element, SubElement

import numpy as np
from pythonfmu.enums import Fmi2Causality, Fmi2Status, Fmi2Variability
from pythonfmu.fmi2slave import Fmi2Slave
from pythonfmu.variables import Real

runtime = importlib.import_module(__name__ + "_rt")

ASSEMBLY = -1  # problem key for a model that cannot be assembled


class StructureSlave(Fmi2Slave):
    """Forces in (``F_*``), displacement/velocity/acceleration out (``u_*``,
    ``v_*``, ``a_*``), element parameters and initial conditions as parameters."""

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        self.spec = json.loads((Path(self.resources) / f"{__name__}.json").read_text())
        self.modelName = self.spec["name"]
        self.description = self.spec["description"]
        self.variables = self.spec["variables"]
        for v in self.variables:
            self.register_variable(Real(v["name"], causality=Fmi2Causality[v["causality"]],
                                        variability=Fmi2Variability[v["variability"]],
                                        description=v["description"]), nested=False)
        blocks = {key: slice(*bounds) for key, bounds in self.spec["blocks"].items()}
        self.blocks = blocks
        self.buf = np.array([v["start"] for v in self.variables], dtype=float)
        self.force, self.out = self.buf[blocks["inputs"]], self.buf[blocks["outputs"]]
        self.params, self.x0 = self.buf[blocks["parameters"]], self.buf[blocks["initial"]]
        self.x = self.x0.copy()
        self.initialized = False
        self.stale = True  # outputs need recomputing
        self.propagator: Any = None  # runtime.Propagator, built lazily from the parameters
        self.problems: dict[int, str] = {}  # value reference (or ASSEMBLY) -> message
        self._set_key: list[int] | None = None
        self._set_idx = np.zeros(0, dtype=np.intp)
        self._set_inputs_only = False
        self._get_key: list[int] | None = None
        self._get_idx = np.zeros(0, dtype=np.intp)

    # ---- dynamics ------------------------------------------------------
    def _dynamics(self) -> Any:
        """The propagator for the current parameters, or None when they are invalid."""
        if self.propagator is None and not self.problems:
            model = self.spec["model"]
            p = self.params
            try:
                if model["type"] == "fe":
                    mats = runtime.assemble(model["n"], np.asarray(model["par"]), np.asarray(model["row"]),
                                            np.asarray(model["col"]), np.asarray(model["val"], dtype=float),
                                            model["kinds"], p, model["rayleigh"])
                    self.propagator = runtime.Propagator(*mats)
                else:
                    r = len(p) // 2
                    omega, zeta = p[:r], p[r:]
                    self.propagator = runtime.Propagator(np.eye(r), np.diag(2 * zeta * omega),
                                                         np.diag(omega**2), np.asarray(model["shapes"]))
            except np.linalg.LinAlgError as err:
                self._problem(ASSEMBLY, f"cannot build the model: the mass matrix is not positive "
                                        f"definite (does every DOF carry mass?): {err}")
        return self.propagator

    def _update_outputs(self) -> None:
        prop = self._dynamics()
        if prop is None:
            self.out[:] = np.nan
        else:
            prop.outputs(self.x if self.initialized else self.x0, self.force, self.out)
        self.stale = False

    # ---- validation ----------------------------------------------------
    def _problem(self, key: int, message: str) -> None:
        self.problems[key] = message
        self.log(message, Fmi2Status.error)

    def _check(self, vr: int, value: float) -> str | None:
        """Why ``value`` is invalid for variable ``vr``, or None."""
        if not math.isfinite(value):
            return "must be finite"
        par = self.blocks["parameters"]
        if par.start <= vr < par.stop:
            bound = self.spec["bounds"][vr - par.start]
            if value < 0 or (bound == "positive" and value == 0):
                return f"must be {bound}"
        return None

    def _set_slow(self, vrs: list[int], values: list[float]) -> None:
        outputs, par = self.blocks["outputs"], self.blocks["parameters"]
        for vr, value in zip(vrs, values):
            v = self.variables[vr]
            if outputs.start <= vr < outputs.stop:
                self.log(f"{v['name']} is an output and cannot be set", Fmi2Status.error)
                continue
            reason = self._check(vr, value)
            if reason:
                self._problem(vr, f"{v['name']} = {value:g} {v['unit']} rejected: {reason} "
                                  f"({v['description']})")
            else:
                self.problems.pop(vr, None)
            self.buf[vr] = value
            if par.start <= vr < par.stop:
                self.propagator = None
                self.problems.pop(ASSEMBLY, None)
        self.stale = True

    # ---- FMI -------------------------------------------------------------
    def set_real(self, vrs: list[int], values: list[float]) -> None:
        if vrs != self._set_key:
            self._set_key = vrs
            self._set_idx = np.array(vrs, dtype=np.intp)
            inputs = self.blocks["inputs"]
            self._set_inputs_only = all(inputs.start <= vr < inputs.stop for vr in vrs)
        if self._set_inputs_only and not self.problems and math.isfinite(sum(values)):
            self.buf[self._set_idx] = values
            self.stale = True
        else:
            self._set_slow(vrs, values)

    def get_real(self, vrs: list[int]) -> list[float]:
        if self.stale:
            self._update_outputs()
        if vrs != self._get_key:
            self._get_key = vrs
            self._get_idx = np.array(vrs, dtype=np.intp)
        return self.buf.take(self._get_idx).tolist()

    def exit_initialization_mode(self) -> None:
        self.x = self.x0.copy()
        self.initialized = True
        self.stale = True

    def do_step(self, current_time: float, step_size: float) -> bool:
        prop = self._dynamics()
        if self.problems or not step_size > 0:
            why = ", ".join("the model" if key == ASSEMBLY else self.variables[key]["name"]
                            for key in self.problems) or f"step size {step_size:g} s"
            self.log(f"step at t = {current_time:g} s rejected: invalid {why}", Fmi2Status.error)
            return False
        self.x = prop.step(self.x, self.force, step_size)
        self.stale = True
        return True

    # ---- model description -------------------------------------------------
    def to_xml(self, model_options: dict[str, str] | None = None) -> Element:
        """pythonfmu's description plus units, deterministic guid, this module as
        modelIdentifier and a complete ModelStructure (Outputs, InitialUnknowns)."""
        root = super().to_xml({} if model_options is None else model_options)
        root.set("guid", self.spec["guid"])
        root.set("variableNamingConvention", "flat")
        root.attrib.pop("generationDateAndTime", None)
        cosim = root.find("CoSimulation")
        cosim.set("modelIdentifier", __name__)
        units = Element("UnitDefinitions")
        for name, base in self.spec["units"].items():
            unit = SubElement(units, "Unit", name=name)
            if base is not None:
                SubElement(unit, "BaseUnit", {k: str(e) for k, e in base.items()})
        root.insert(list(root).index(cosim) + 1, units)
        for sv, v in zip(root.find("ModelVariables"), self.variables):
            real = sv.find("Real")
            real.set("unit", v["unit"])
            if "start" in real.attrib:
                real.set("start", repr(float(self.buf[int(sv.get("valueReference"))])))
        structure = root.find("ModelStructure")
        structure.clear()
        outputs = self.blocks["outputs"]
        n = self.blocks["inputs"].stop - self.blocks["inputs"].start
        out_el, init_el = SubElement(structure, "Outputs"), SubElement(structure, "InitialUnknowns")
        for vr in range(outputs.start, outputs.stop):
            index = str(vr + 1)  # value reference = registration order = index - 1
            # displacement and velocity do not depend on the inputs directly
            deps = {} if vr >= outputs.start + 2 * n else {"dependencies": ""}
            SubElement(out_el, "Unknown", index=index, **deps)
            SubElement(init_el, "Unknown", index=index)
        return root
