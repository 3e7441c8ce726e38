"""Spectral UFF 58 datasets (function types 2 auto spectrum, 3 cross
spectrum, 4 FRF, 6 coherence, 9 PSD) to the arrays of an FRF file
(``docs/frf-format.md``), one per reference (force) channel.

Record 6 gives the response node and direction and the reference node and
direction (a negative direction negates the data: both signs multiply);
ID line 1 ``<estimator> <response> / <force>`` (as ``structbench export``
writes it) gives the channel names, quantities and the model's direction
names, else record 9's specific data type the quantity and the sensor map's
``[directions]`` the direction names. Units: the FRF's ordinate label
(record 9) over its denominator label (record 10, default ``N``), both to
SI (``(m/s^2)/N`` for ``g`` over ``lbf``); auto and cross spectra are taken
to be in the same units as the FRF's response and force (squared, or their
product). The abscissa must be frequency (specific data type 18 or 0, units
``Hz``) and the same in every dataset of one reference.

This package writes no FRF files: :func:`frf_parts` returns plain arrays
and the API builds the FRF file from them.
"""
from __future__ import annotations

import re
from typing import Any

import numpy as np

from structbench.models.channels import ROTATIONS, unit as si_unit
from structbench.models.errors import UserError

from .sensor_map import UFF_DIRECTIONS, SensorMap
from .signals import parse_name
from .uff58 import Record58
from .units import conversion

SPECTRAL = {2: "auto spectrum", 3: "cross spectrum", 4: "frequency response function", 6: "coherence",
            9: "power spectral density"}
QUANTITIES = {8: "displacement", 11: "velocity", 12: "acceleration", 9: "force", 13: "force"}
_NAMES = re.compile(r"^(?:(\S+) )?(\S+) / (\S+)\s*$")


def _where(file: str, r: Record58, record: int | None = None) -> str:
    return f"{file} dataset {r.index}" + (f" record {record}" if record else "")


def _channels(file: str, r: Record58, smap: SensorMap) -> tuple[dict[str, Any], dict[str, Any], str | None]:
    """(response, force) channel descriptions and the estimator named in ID line 1."""
    found = _NAMES.match(r.id_lines[0].strip())
    named = [parse_name(found.group(2)), parse_name(found.group(3))] if found else [{}, {}]

    def channel(i: int, node: int, code: int, quantity: str | None) -> dict[str, Any]:
        direction = smap.direction(UFF_DIRECTIONS[abs(code) - 1]) if 1 <= abs(code) <= 6 else None
        q = named[i].get("quantity") or quantity
        d = named[i].get("direction") or direction
        n = named[i].get("node") or node
        if q is None or d is None or not n:
            raise UserError(f"{'response' if i == 0 else 'reference'} has no quantity, node or direction "
                            "(record 6, ID line 1)", field=_where(file, r, 6))
        return {"name": f"{q}_{n}_{d}", "quantity": q, "unit": si_unit(q, d), "node": int(n), "direction": d}

    response = channel(0, r.node, r.direction, QUANTITIES.get(r.ordinate.data_type) or "acceleration")
    force = channel(1, r.reference_node, r.reference_direction, "force")
    estimator = found.group(1) if found and found.group(1) in ("H1", "H2", "Hv") else None
    return response, force, estimator


def _factor(label: str, default: str, quantity: str, rotation: bool, where: str) -> float:
    unit = conversion(label or default, where)
    if unit.quantity != quantity or unit.rotation != rotation:
        raise UserError(f"unit {label!r} is a {unit.dimension}, not a {quantity}", field=where)
    return unit.factor


def frf_parts(file: str, records: list[Record58], smap: SensorMap) -> list[dict[str, Any]]:
    """The FRF file arrays (keywords of ``structbench.identifier.io.frf_files.Frf``,
    ``force`` and ``responses`` as dicts) of every reference channel of the
    spectral ``records`` of one file."""
    groups: dict[str, dict[str, Any]] = {}
    autos = []
    for r in records:
        if r.function_type not in SPECTRAL:
            continue
        if (r.function_type in (3, 4)) != np.iscomplexobj(r.y):
            kind = "complex" if r.function_type in (3, 4) else "real"
            raise UserError(f"function type {r.function_type} ({SPECTRAL[r.function_type]}) needs {kind} data, "
                            f"not ordinate data type {r.ordinate_type}", field=_where(file, r, 6))
        if r.abscissa.data_type not in (0, 18) or (r.abscissa.units or "Hz").lower() != "hz":
            raise UserError(f"abscissa data type {r.abscissa.data_type} in {r.abscissa.units!r}: spectra need a "
                            "frequency axis (18) in Hz", field=_where(file, r, 8))
        if r.function_type in (2, 9):  # an auto spectrum's reference is itself: placed below
            autos.append(r)
            continue
        response, force, estimator = _channels(file, r, smap)
        group = groups.setdefault(force["name"], {"force": force, "frequency": r.x, "responses": {},
                                                  "estimator": estimator, "datasets": []})
        if r.x.shape != group["frequency"].shape or not np.allclose(r.x, group["frequency"], rtol=1e-9, atol=0):
            raise UserError("frequency lines differ from those of the reference's first dataset",
                            field=_where(file, r, 7))
        group["estimator"] = group["estimator"] or estimator
        group["datasets"].append(r.index)
        sign = (-1.0 if r.direction < 0 else 1.0) * (-1.0 if r.reference_direction < 0 else 1.0)
        entry = group["responses"].setdefault(response["name"], {"channel": response, "parts": {}})
        entry["parts"].setdefault(r.function_type, (r, sign))
    for r in autos:
        response = _channels(file, r, smap)[0]
        for group in groups.values():
            if response["name"] in group["responses"] or response["name"] == group["force"]["name"]:
                entry = group["responses"].setdefault(response["name"], {"channel": response, "parts": {}})
                entry["parts"].setdefault(r.function_type, (r, 1.0))
                group["datasets"].append(r.index)
    return [_arrays(file, g) for g in groups.values()]


def _arrays(file: str, g: dict[str, Any]) -> dict[str, Any]:
    force, m = g["force"], g["frequency"].size
    names = [n for n, e in g["responses"].items() if 4 in e["parts"]]
    if not names:
        raise UserError(f"spectra of reference {force['name']} but no FRF (function type 4) for it", field=file)
    c = len(names)
    frf, coherence = np.empty((c, m), complex), np.full((c, m), np.nan)
    auto_response, cross = np.full((c, m), np.nan), np.full((c, m), np.nan + 0j)
    auto_force = np.full(m, np.nan)
    psd = False
    for i, name in enumerate(names):
        parts, response = g["responses"][name]["parts"], g["responses"][name]["channel"]
        r, sign = parts[4]
        f_response = _factor(r.ordinate.units, response["unit"], response["quantity"],
                             response["direction"] in ROTATIONS, _where(file, r, 9))
        f_force = _factor(r.denominator.units, force["unit"], "force", force["direction"] in ROTATIONS,
                          _where(file, r, 10))
        frf[i] = sign * r.y * (f_response / f_force)
        if 6 in parts:
            coherence[i] = parts[6][0].y
        if 3 in parts:
            cross[i] = parts[3][1] * parts[3][0].y * (f_response * f_force)
        for kind in (9, 2):
            if kind in parts:
                auto_response[i], psd = parts[kind][0].y * f_response**2, psd or kind == 9
                break
        for kind in (9, 2):
            if kind in g["responses"].get(force["name"], {}).get("parts", {}):
                auto_force, psd = g["responses"][force["name"]]["parts"][kind][0].y * f_force**2, psd or kind == 9
                break
    nan = np.full((2, c, m), np.nan)
    return {"frequency": np.asarray(g["frequency"], dtype=float), "frf": frf, "coherence": coherence,
            "random_error": np.full((c, m), np.nan), "magnitude_band": nan, "phase_band": nan.copy(),
            "n_averages": np.zeros(m, dtype=np.int64), "n_effective": np.full(m, np.nan),
            "auto_force": np.asarray(auto_force, dtype=float), "auto_response": auto_response, "cross": cross,
            "force": force, "responses": [g["responses"][n]["channel"] for n in names],
            "estimator": g["estimator"] or "imported", "analysis": "imported", "window": "unknown", "segment": 0,
            "overlap": 0.0, "confidence": float("nan"), "dt": float("nan"),
            "spectra_scaling": "density" if psd else "as in the file (UFF auto/cross spectra)",
            "attrs": {"source": file, "datasets": g["datasets"]}}
