"""Prepare the FMU a campaign runs on: the external FMU or the structure's
(built when missing), its variables checked against the campaign's mapping,
its checksum, and the :class:`Bench` the workers receive.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg as la

from structbench.fmus import build_fmu
from structbench.models import ModalModel

from .campaign import Campaign
from .excitation import Excitation, Impulse, Initial
from .external import BUILTIN, VariableMap, fmu_variables
from .fmu_options import FmuOptions
from .fmu_session import fmu_checksum


@dataclass(frozen=True)
class Bench:
    """A campaign as the workers need it (picklable; no model).

    ``impulse_states`` maps a DOF to the initial-condition variables (and
    their values per N s) of a unit impulse there, for ``initial-velocity``
    impulses; ``locations`` maps node ids to coordinates (m); ``options``:
    the interface, substeps and solver tolerance the FMU runs with.
    """

    campaign: str
    structure: str
    fmu: str
    fmu_sha256: str
    parameters: Mapping[str, float]
    mapping: VariableMap
    locations: Mapping[int, tuple[float, float, float]]
    impulse_states: Mapping[tuple[int, str], Mapping[str, float]] = field(default_factory=dict)
    options: FmuOptions = field(default_factory=FmuOptions)

    @property
    def fmu_name(self) -> str:
        return Path(self.fmu).name

    def initial_values(self, items: Sequence[Excitation]) -> dict[str, float]:
        """FMU initial-condition variables set by a test's excitation."""
        values: dict[str, float] = {}
        for item in items:
            if isinstance(item, Initial):
                for key, v in (("initial_displacement", item.displacement), ("initial_velocity", item.velocity)):
                    if v:
                        name = self.mapping.variable(key, item.node, item.direction)
                        values[name] = values.get(name, 0.0) + v
            elif isinstance(item, Impulse) and item.method == "initial-velocity":
                for name, per_unit in self.impulse_states[(item.node, item.direction)].items():
                    values[name] = values.get(name, 0.0) + per_unit * item.impulse
        return values


def impulse_states(campaign: Campaign) -> dict[tuple[int, str], dict[str, float]]:
    """Initial-condition variables per N s of an exact impulse at each DOF
    where the campaign applies an ``initial-velocity`` impulse:
    ``v0 = M^-1 e`` (finite elements), ``qd0_r = phi_r(x)`` (modal)."""
    dofs = {(i.node, i.direction) for t in campaign.tests for i in t.excitation
            if isinstance(i, Impulse) and i.method == "initial-velocity"}
    model = campaign.true_model
    out = {}
    for dof in sorted(dofs):
        j = model.dof_index(*dof)
        if isinstance(model, ModalModel):
            out[dof] = {f"qd0_{r + 1}": float(v) for r, v in enumerate(model.shapes[j])}
        else:
            unit = np.zeros(model.n_dof)
            unit[j] = 1.0
            v0 = la.solve(model.mass().toarray(), unit, assume_a="pos")
            out[dof] = {BUILTIN.variable("initial_velocity", n, d): float(v)
                        for (n, d), v in zip(model.dofs, v0)}
    return out


def prepare_fmu(campaign: Campaign, fmu_dir: str | Path) -> Bench:
    """The FMU to run (the external one, or the structure's built into
    ``fmu_dir`` if missing), checked against the campaign's variable mapping,
    as the :class:`Bench` the workers run."""
    fmu = campaign.fmu if campaign.fmu is not None else build_fmu(campaign.model, fmu_dir)
    campaign.check_variables(fmu_variables(fmu), fmu.name)
    nodes = {c.node for t in campaign.tests for c in t.channels} | {
        i.node for t in campaign.tests for i in t.excitation}
    return Bench(campaign.name, campaign.structure, str(fmu), fmu_checksum(fmu), dict(campaign.parameters),
                 campaign.mapping, {n: campaign.location(n) for n in sorted(nodes)},
                 impulse_states(campaign) if campaign.model is not None else {}, campaign.fmu_options)
