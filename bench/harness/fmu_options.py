"""How the harness drives an FMU: the campaign's top-level ``interface``,
``substeps`` and ``[solver]`` keys (``docs/campaign-format.md``).

- ``interface``: ``"co-simulation"`` (the FMU's own solver, one ``doStep``
  per communication step) or ``"model-exchange"`` (the harness integrates
  the FMU's derivatives with fmpy's CVode, adaptive steps); default: the
  FMU's co-simulation when it offers one, else its model exchange.
- ``substeps = N``: N ``doStep`` calls of ``step / N`` s per communication
  step, the input held over them (co-simulation only; N times the FMU calls).
- ``[solver] relative_tolerance``: CVode's relative tolerance (model
  exchange only; its absolute tolerance is that times each state's nominal
  value), default 1e-10.

Fails (:class:`~.toml_table.CampaignError`, naming the line) on a bad value,
an interface the FMU does not offer, or an option of the other interface.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .toml_table import Table

INTERFACES = ("co-simulation", "model-exchange")
MAX_SUBSTEPS = 100_000
DEFAULT_RTOL = 1e-10


@dataclass(frozen=True)
class FmuOptions:
    """``interface`` (one of :data:`INTERFACES`), ``substeps`` (FMU steps per
    communication step, >= 1), ``relative_tolerance`` (CVode, model exchange)
    and whether the FMU is ``external`` (not built by structbench)."""

    interface: str = "co-simulation"
    substeps: int = 1
    relative_tolerance: float = DEFAULT_RTOL
    external: bool = False

    def finer(self) -> "FmuOptions":
        """The same FMU at half the step: substeps doubled (co-simulation) or
        the tolerance divided by 100 (model exchange), for the step check."""
        if self.interface == "model-exchange":
            return FmuOptions(self.interface, self.substeps, self.relative_tolerance / 100, self.external)
        return FmuOptions(self.interface, 2 * self.substeps, self.relative_tolerance, self.external)

    def describe(self) -> str:
        """``co-simulation, 20 substeps`` or ``model-exchange (CVode, rtol 1e-10)``."""
        if self.interface == "model-exchange":
            return f"model-exchange (CVode, relative_tolerance {self.relative_tolerance:g})"
        return f"co-simulation, {self.substeps} substep{'s' if self.substeps > 1 else ''} per step"


def offered(fmu: Path) -> tuple[str, ...]:
    """The interfaces an FMU's model description offers."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu), validate=False)
    return tuple(name for name, part in zip(INTERFACES, (md.coSimulation, md.modelExchange)) if part is not None)


def read_fmu_options(top: Table, fmu: Path | None) -> FmuOptions:
    """The options of a campaign's top-level table ``top``; ``fmu`` is the
    external FMU (None: a structure structbench builds, co-simulation only)."""
    have = offered(fmu) if fmu is not None else ("co-simulation",)
    interface = top.string("interface", have[0] if have else "co-simulation", INTERFACES)
    if interface not in have:
        name = fmu.name if fmu is not None else "the FMU structbench builds for this structure"
        raise top.error("interface", f"{name} offers no {interface} (it offers {' and '.join(have) or 'neither'})")
    substeps = top.integer("substeps", 1, low=1)
    if substeps > MAX_SUBSTEPS:
        raise top.error("substeps", f"at most {MAX_SUBSTEPS}, got {substeps}")
    if substeps > 1 and interface == "model-exchange":
        raise top.error("substeps", "substeps are for co-simulation; model exchange chooses its own steps "
                                    "([solver] relative_tolerance sets their accuracy)")
    solver = top.table("solver")
    solver.allow(("relative_tolerance",), "[solver]")
    rtol = solver.number("relative_tolerance", DEFAULT_RTOL, positive=True)
    if solver.data and interface != "model-exchange":
        raise top.error("solver", "[solver] is for interface = \"model-exchange\" (CVode); co-simulation "
                                  "FMUs integrate with their own solver (use substeps)")
    if rtol >= 1:
        raise solver.error("relative_tolerance", f"must be below 1, got {rtol}")
    return FmuOptions(interface, substeps, rtol, fmu is not None)
