"""Modal results as UFF dataset 55 (data at nodes), in and out.

Published layout (columns fixed): records 1-5 ID lines ``80A1``; record 6
``6I10``: model type (1 structural), analysis type (2 normal mode, 3
complex eigenvalue first order, 7 second order), data characteristic (2:
3 DOF x y z, 3: 6 DOF x y z rx ry rz), specific data type (8 displacement,
11 velocity, 12 acceleration), data type (2 real, 5 complex) and values per
node NDV (3 or 6); record 7 ``8I10``: number of integer values (2), of real
values (4 or 6), load case, mode number; record 8 ``6E13.5``: normal mode:
frequency (Hz), modal mass, viscous damping ratio, hysteretic damping
ratio; complex eigenvalue: Re and Im of the eigenvalue ``s`` (rad/s), modal
A and B (complex); then per node record 9 ``I10`` (node) and record 10
``6E13.5`` (NDV values, real and imaginary part alternating when complex,
six per line).

Import: one results run (docs/results-format.md, modal schema) per load
case, modes by ascending frequency: ``omega`` = 2 pi f or ``|s|`` (rad/s),
``damping`` the viscous damping ratio or ``-Re(s)/|s|``; the sensors are the
(node, direction) pairs that are non-zero in some mode, named
``<quantity>_<node>_<direction>`` (direction codes through the sensor map's
``[directions]``, else the file's own hint, below); standard errors NaN.
Export: one dataset per mode, load case = run index + 1; complex shapes as
analysis type 3 with ``s = omega (-zeta + i sqrt(1 - zeta^2))``, real shapes
as type 2; ID line 3 ``structbench directions 3=w 5=theta`` records the
model's names of the direction codes so that import gives them back.
"""
from __future__ import annotations

import math
import re
from collections.abc import Callable
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models.channels import ROTATIONS
from structbench.models.errors import UserError

from .sensor_map import UFF_DIRECTIONS
from .uff58 import Dataset

CODES = {"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6, "u": 1, "v": 2, "w": 3, "theta": 5}
QUANTITY = {8: "displacement", 11: "velocity", 12: "acceleration"}
SPECIFIC = {"displacement": 8, "velocity": 11, "acceleration": 12}
_HINT = re.compile(r"^structbench directions((?: \d=\S+)+)\s*$")


def _numbers(fields: list[str], where: str) -> list[float]:
    try:
        return [float(v.replace("D", "E").replace("d", "e")) for v in fields]
    except ValueError:
        raise UserError(f"{' '.join(fields)[:60]!r} are not numbers (E13.5 each)", field=where) from None


def _split(line: str, width: int) -> list[str]:
    line = line.rstrip()
    return [line[i:i + width] for i in range(0, len(line), width) if line[i:i + width].strip()]


def _ints(line: str, count: int, where: str) -> list[int]:
    fields = [line.ljust(10 * count)[10 * i:10 * i + 10].strip() or "0" for i in range(count)]
    try:
        return [int(v) for v in fields]
    except ValueError:
        raise UserError(f"{line.strip()[:60]!r} are not {count} integers (I10 each)", field=where) from None


def _mode(file: str, d: Dataset) -> dict[str, Any]:
    """One dataset 55: load case, mode, omega (rad/s), zeta, quantity and
    {(node, code): complex value}."""
    where = f"{file} dataset {d.index} (55)"
    lines = list(d.lines)
    if len(lines) < 8:
        raise UserError("the dataset ends before record 8 (truncated)", field=where)
    _, analysis, _, specific, data_type, ndv = _ints(lines[5], 6, f"{where} record 6")
    if analysis not in (2, 3, 7):
        raise UserError(f"analysis type {analysis}: only modes (2 normal, 3/7 complex eigenvalue) are modal "
                        "results", field=f"{where} record 6 field 2")
    if data_type not in (2, 5) or ndv not in (3, 6):
        raise UserError(f"data type {data_type} with {ndv} values per node: need 2 (real) or 5 (complex) and 3 "
                        "or 6 values", field=f"{where} record 6")
    n_int, n_real = _ints(lines[6], 2, f"{where} record 7")
    load_case, mode = (_ints(lines[6], 2 + n_int, f"{where} record 7")[2:4] + [0, 0])[:2]
    real_lines = max(1, math.ceil(n_real / 6))
    reals = _numbers(sum((_split(ln, 13) for ln in lines[7:7 + real_lines]), []), f"{where} record 8")
    if len(reals) < (4 if analysis == 2 else 2):
        raise UserError(f"{len(reals)} real values; the analysis type needs {4 if analysis == 2 else 6}",
                        field=f"{where} record 8")
    if analysis == 2:
        omega, zeta = 2 * math.pi * reals[0], reals[2]
    else:
        s = complex(reals[0], reals[1])
        omega, zeta = abs(s), (-s.real / abs(s) if abs(s) else 0.0)
    per_node = ndv * (2 if data_type == 5 else 1)
    body, values = lines[7 + real_lines:], {}
    i = 0
    while i < len(body):
        if not body[i].strip():
            i += 1
            continue
        node = _ints(body[i], 1, f"{where} record 9")[0]
        row: list[float] = []
        i += 1
        while len(row) < per_node:
            if i >= len(body):
                raise UserError(f"node {node}: {len(row)} of its {per_node} values (truncated)",
                                field=f"{where} record 10")
            row += _numbers(_split(body[i], 13), f"{where} record 10 (node {node})")
            i += 1
        data = np.array(row[:per_node])
        shape = data[0::2] + 1j * data[1::2] if data_type == 5 else data.astype(complex)
        values |= {(node, code + 1): v for code, v in enumerate(shape)}
    return {"load_case": load_case, "mode": mode, "omega": omega, "zeta": zeta, "dataset": d.index,
            "quantity": QUANTITY.get(specific, "displacement"), "values": values, "ids": lines[:5]}


def _principal(shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real shapes (principal direction, max |.| = 1, largest entry
    positive) and MPC of complex shapes (m, k), as the modal method gives them."""
    re_, im = shapes.real, shapes.imag
    theta = 0.5 * np.arctan2(2 * np.sum(re_ * im, 0), np.sum(re_**2, 0) - np.sum(im**2, 0))
    rotated = (shapes * np.exp(-1j * theta)).real
    peak = rotated[np.argmax(np.abs(rotated), axis=0), np.arange(rotated.shape[1])]
    sxx, syy, sxy = np.sum(re_**2, 0), np.sum(im**2, 0), np.sum(re_ * im, 0)
    total = sxx + syy
    mpc = np.where(total > 0, (np.sqrt((sxx - syy) ** 2 + 4 * sxy**2) / np.where(total > 0, total, 1.0)) ** 2, 1.0)
    return rotated / np.where(peak == 0, 1.0, peak), mpc


def read_uff55(file: str, datasets: list[Dataset], direction: Callable[[str], str | None],
               structure: str = "") -> list[dict[str, Any]]:
    """The results runs (modal schema, plain dicts) of a file's datasets 55,
    one per load case; ``direction`` maps a UFF code name (``x`` .. ``rz``) to
    the model's name (None: use the file's hint, else the code name)."""
    modes = [_mode(file, d) for d in datasets if d.kind == 55]
    hint: dict[int, str] = {}
    for m in modes:
        found = _HINT.match(m["ids"][2].strip())
        if found:
            hint |= {int(k): v for k, v in (p.split("=", 1) for p in found.group(1).split())}
    runs = []
    for load_case in sorted({m["load_case"] for m in modes}):
        mine = sorted((m for m in modes if m["load_case"] == load_case), key=lambda m: m["omega"])
        dofs = sorted({k for m in mine for k, v in m["values"].items() if v != 0})
        names = [direction(UFF_DIRECTIONS[c - 1]) or hint.get(c, UFF_DIRECTIONS[c - 1]) for _, c in dofs]
        quantity = mine[0]["quantity"]
        order = sorted(range(len(dofs)), key=lambda i: (dofs[i][0], names[i]))
        shapes = np.array([[m["values"].get(dofs[i], 0) for m in mine] for i in order], dtype=complex)
        norms = np.linalg.norm(shapes, axis=0)
        shapes = shapes / np.where(norms > 0, norms, 1.0)
        real, mpc = _principal(shapes) if shapes.size else (shapes.real, np.ones(len(mine)))
        omega = [m["omega"] for m in mine]
        runs.append({
            "method": "uff55", "structure": structure, "repetition": max(load_case - 1, 0), "tests": [],
            "status": "ok", "message": "", "parameters": [], "iterations": None, "history": [],
            "misfit_history": [], "omega": omega, "eigenvalues": [w * w for w in omega],
            "mode_shapes": real.T.tolist(), "sensors": [f"{quantity}_{dofs[i][0]}_{names[i]}" for i in order],
            "damping": [m["zeta"] for m in mine], "omega_std": [math.nan] * len(mine),
            "damping_std": [math.nan] * len(mine), "mpc": mpc.tolist(),
            "mode_shapes_complex": [[[float(v.real), float(v.imag)] for v in col] for col in shapes.T],
            "details": {"source": file, "load_case": load_case, "datasets": [m["dataset"] for m in mine],
                        "modes": [m["mode"] for m in mine], "id_line_1": mine[0]["ids"][0].strip()}})
    return runs


def results_document(runs: list[dict[str, Any]], campaign: str, structure: str, file: str) -> dict[str, Any]:
    """A results file (docs/results-format.md) holding imported runs."""
    try:
        software = f"structbench {version('structbench')}"
    except PackageNotFoundError:
        software = "structbench unknown"
    return {"format": "structbench-result", "format_version": 1, "method": "uff55", "campaign": campaign,
            "structure": structure, "model": structure, "software": software,
            "options": {"group": None, "test": None, "joint": False, "file": file}, "runs": runs}


def _sensor(name: str) -> tuple[str, int, str]:
    quantity, node, direction = name.split("_", 2)
    return quantity, int(node), direction


def _dataset(run: dict[str, Any], k: int, case: int, shape: np.ndarray, complex_: bool, ids: list[str],
             nodes: dict[int, dict[int, int]], ndv: int, specific: int) -> str:
    omega, zeta = float(run["omega"][k]), float((run.get("damping") or [0.0] * len(run["omega"]))[k])
    zeta = zeta if math.isfinite(zeta) else 0.0
    lines = ["    -1", "    55"] + [f"{(t or 'NONE')[:80]:<80s}" for t in ids]
    lines.append(f"{1:10d}{3 if complex_ else 2:10d}{3 if ndv == 6 else 2:10d}{specific:10d}"
                 f"{5 if complex_ else 2:10d}{ndv:10d}")
    if complex_:
        s = omega * complex(-zeta, math.sqrt(max(1 - zeta * zeta, 0.0)))
        lines += [f"{2:10d}{6:10d}{case:10d}{k + 1:10d}", "".join(f"{v:13.5E}" for v in (s.real, s.imag, 0, 0, 0, 0))]
    else:
        lines += [f"{2:10d}{4:10d}{case:10d}{k + 1:10d}",
                  "".join(f"{v:13.5E}" for v in (omega / (2 * math.pi), 0.0, zeta, 0.0))]
    for node, rows in sorted(nodes.items()):
        values = np.zeros(ndv, dtype=complex)
        for code, row in rows.items():
            values[code - 1] = shape[row]
        flat = np.column_stack([values.real, values.imag]).ravel() if complex_ else values.real
        lines.append(f"{node:10d}")
        lines += ["".join(f"{v:13.5E}" for v in flat[i:i + 6]) for i in range(0, flat.size, 6)]
    return "\n".join(lines + ["    -1"]) + "\n"


def write_uff55(path: str | Path, runs: list[dict[str, Any]], title: str) -> Path:
    """Modal runs (dicts of docs/results-format.md) as datasets 55 in a new
    ASCII file; a sensor whose direction has no UFF code is a :class:`UserError`."""
    text = []
    for r, run in enumerate(runs):
        sensors = [_sensor(s) for s in run.get("sensors", [])]
        nodes: dict[int, dict[int, int]] = {}
        names: dict[int, str] = {}
        for row, (_, node, direction) in enumerate(sensors):
            code = CODES.get(direction)
            if code is None:
                raise UserError(f"direction {direction!r} of sensor {run['sensors'][row]!r} has no UFF direction "
                                f"code ({', '.join(CODES)})", field=f"{title} runs[{r}].sensors")
            if code in nodes.setdefault(node, {}):
                raise UserError(f"two sensors at node {node} direction {direction!r}",
                                field=f"{title} runs[{r}].sensors")
            nodes[node][code], names[code] = row, direction
        ndv = 6 if any(d in ROTATIONS for _, _, d in sensors) else 3
        quantities = {q for q, _, _ in sensors}
        specific = SPECIFIC.get(quantities.pop(), 8) if len(quantities) == 1 else 8
        complex_ = bool(run.get("mode_shapes_complex"))
        shapes = (np.array(run["mode_shapes_complex"], dtype=float) @ np.array([1, 1j]) if complex_
                  else np.array(run.get("mode_shapes") or [], dtype=float))
        hint = "structbench directions " + " ".join(f"{c}={n}" for c, n in sorted(names.items()))
        for k in range(len(run.get("omega", []))):
            ids = [f"{title} mode {k + 1}", f"run {r} repetition {run.get('repetition', 0)} "
                   f"tests {' '.join(run.get('tests', []))}"[:80], hint, f"structure {run.get('structure', '')}",
                   f"omega {float(run['omega'][k]):.12g} rad/s"]
            text.append(_dataset(run, k, r + 1, shapes[k] if len(shapes) else np.zeros(len(sensors)),
                                 complex_, ids, nodes, ndv, specific))
    path = Path(path)
    path.write_text("".join(text))
    return path
