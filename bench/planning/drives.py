"""Excitation points: where to put the impulse of a free decay (``--drives FILE``).

Candidates: TOML ``[[drives]]`` entries (``nodes`` = list or ``"all"``,
optional ``dirs``: default every free direction of those nodes) or CSV rows
``node,dir`` under that header. The test must be a free decay of one
impulse ``I`` (N s); a candidate moves it to DOF ``j``, which sets the
modal initial velocities ``qd0_r = I phi_jr`` (mass-normalised shapes) and so
the amplitudes ``B_r = qd0_r / wd_r`` every channel sees (:mod:`.free_decay`).

For each candidate the modal bound is computed on the plan's sensors (the
chosen layout's with ``--candidates``, else the test's modal channels): the
modes visible from that point (:func:`.free_decay.visible`) and their
information ``J = sum_c L_c^T Q L_c / sigma_c^2`` on those modes alone, as
``plan --method modal`` computes it for a test driven there. The target
modes are the layout's (with ``--candidates``), else the lowest
``target_modes`` (default all) of the modes below 0.8 x Nyquist that some
candidate determines to :data:`~.layouts.PRECISE` (relative omega standard
error; the layouts' rule for the modes planned for). Ranking: fewest target
modes left invisible (``missed``), then least RMS of the predicted
relative frequency errors ``std(omega_r) / omega_r`` over the target modes
seen. Cost: one ``Q`` (O(m R^2)) per distinct set of visible modes and
O(C R^3) per candidate.

Fails (:class:`UserError`) for a test that is not one impulse, an
unreadable file, a candidate that is not a model DOF, no candidate, or
target modes outside 1..(modes some candidate determines).
"""
from __future__ import annotations

import csv
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from structbench.harness.excitation import Impulse
from structbench.harness.test_entries import TestSpec
from structbench.models import Model
from structbench.models.errors import UserError

from . import free_decay as fd
from .layouts import PRECISE


def read_drives(path: str | Path, model: Model) -> list[tuple[int, str]]:
    """(node, dir) per candidate excitation point, in file order, duplicates dropped."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise UserError(f"{path}: cannot read ({err})", field="--drives") from None
    out: list[tuple[int, str]] = []
    if path.suffix.lower() == ".csv":
        rows = list(csv.DictReader(text.splitlines()))
        if not rows or set(rows[0]) != {"node", "dir"}:
            raise UserError(f"{path}: expected the header node,dir", field="--drives")
        for i, row in enumerate(rows, start=2):
            try:
                out.append((int(row["node"]), str(row["dir"]).strip()))
            except (TypeError, ValueError):
                raise UserError(f"{path}:{i}: node must be an integer", field="--drives") from None
    else:
        try:
            entries = tomllib.loads(text).get("drives", [])
        except tomllib.TOMLDecodeError as err:
            raise UserError(f"{path}: {err}", field="--drives") from None
        for i, e in enumerate(entries, start=1):
            if not isinstance(e, dict) or "nodes" not in e:
                raise UserError(f"{path}: drives[{i}] needs nodes", field="--drives")
            dofs = [d for d in model.dofs if e["nodes"] == "all" or d[0] in e["nodes"]]
            out += [d for d in dofs if "dirs" not in e or d[1] in e["dirs"]]
    for n, d in out:
        try:
            model.dof_index(n, d)
        except Exception:
            raise UserError(f"{path}: drive ({n}, {d!r}) is not a free DOF of {model.name}",
                            field="--drives") from None
    if not out:
        raise UserError(f"{path}: no candidate excitation point", field="--drives")
    return list(dict.fromkeys(out))


def the_impulse(test: TestSpec) -> Impulse:
    """The test's one impulse; fails for any other excitation."""
    items = list(test.excitation)
    if len(items) != 1 or not isinstance(items[0], Impulse):
        raise UserError(f"excitation points are ranked for a free decay of one impulse; test {test.group!r} has "
                        f"{', '.join(i.kind for i in items) or 'no excitation'}", field="--drives")
    return items[0]


def _bound(d: fd.Decay, rows: np.ndarray, orders: np.ndarray, ratio: np.ndarray,
           cache: dict[bytes, tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """(visible (R,) bool, predicted relative omega std (R,), inf where not visible)
    of the free decay ``d`` through channels ``rows``, ``orders`` with noise ratios ``ratio``."""
    beta = fd.amplitudes(d, rows, orders)
    sigma = fd.channel_sigma(beta, ratio, fd.cached_bases(d, cache)[0])
    seen = fd.visible(d, beta, sigma)
    rel = np.full(d.omega.size, np.inf)
    if seen.any():
        sub = fd.Decay(d.omega[seen], d.zeta[seen], d.A[seen], d.B[seen], d.shapes[:, seen], d.dt, d.m)
        _, Q = fd.cached_bases(sub, cache)
        J = fd.channel_information(beta[:, seen], sigma, Q).sum(axis=0)
        try:
            rel[seen] = np.sqrt(fd.omega_zeta_covariance(sub, J)[:, 0, 0]) / sub.omega
        except np.linalg.LinAlgError:
            pass
    return seen, rel


def driven(base: fd.Decay, model: Model, point: tuple[int, str], impulse: float) -> fd.Decay:
    """``base``'s modes decaying after an impulse ``impulse`` at ``point``
    (node, dir) alone: ``A = 0``, ``B_r = I phi_jr / wd_r``."""
    qd0 = impulse * base.shapes[model.dof_index(*point)]
    return fd.Decay(base.omega, base.zeta, np.zeros_like(qd0), qd0 / base.wd, base.shapes, base.dt, base.m)


def sensor_channels(model: Model, test: TestSpec,
                    sensors: list[tuple[int, str, str]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shape rows, derivative orders and noise ratios (C,) of the channels
    ``sensors`` (node, dir, quantity); fails if none has noise."""
    rows = np.array([model.dof_index(n, d) for n, d, _ in sensors])
    orders = np.array([fd.ORDER[q] for _, _, q in sensors])
    ratio = np.array([test.noise.ratio(q) for _, _, q in sensors])
    if not ratio.any():
        raise UserError("the test has no sensor noise on its motion channels: the bounds are zero", field="noise")
    return rows, orders, ratio


def point_bounds(model: Model, base: fd.Decay, impulse: float, drives: list[tuple[int, str]],
                 channels: tuple[np.ndarray, np.ndarray, np.ndarray],
                 cache: dict[bytes, tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Per candidate point (D,) the visible modes (D, R) bool and predicted
    relative omega standard errors (D, R) (inf where not visible) through
    ``channels`` (:func:`sensor_channels`); ``cache`` keeps the bases per
    set of visible modes."""
    out = [_bound(driven(base, model, p, impulse), *channels, cache) for p in drives]
    return np.array([o[0] for o in out]).reshape(len(drives), -1), np.array([o[1] for o in out]).reshape(
        len(drives), -1)


def target_index(base: fd.Decay, rel: np.ndarray, target_modes: int | None,
                 targets: list[float] | None) -> np.ndarray:
    """Indices into ``base``'s modes of the target modes: those at ``targets``
    (rad/s) if given, else the lowest ``target_modes`` (default all) of the
    modes some row of ``rel`` (D, R) determines to :data:`PRECISE`."""
    if targets is not None:
        return np.flatnonzero(np.isclose(base.omega[:, None], np.asarray(targets)[None, :], rtol=1e-9).any(axis=1))
    good = np.flatnonzero(np.any(rel < PRECISE, axis=0))
    if not good.size:
        raise UserError(f"no mode of the test is determined to {PRECISE:.1%} from any candidate excitation point",
                        field="--drives")
    count = good.size if target_modes is None else int(target_modes)
    if not 1 <= count <= good.size:
        raise UserError(f"must be between 1 and the {good.size} modes the candidate excitation points "
                        "determine", field="--target-modes")
    return good[:count]


def score_row(point: tuple[int, str], seen: np.ndarray, rel: np.ndarray, index: np.ndarray,
              omega: np.ndarray) -> dict[str, Any]:
    """A ranking row: the target modes (``index`` into ``omega``) not visible
    from ``point`` (rad/s) and the RMS and median of ``rel`` over those seen."""
    hit = index[seen[index]]
    return {"node": int(point[0]), "dir": point[1], "missed": [float(w) for w in omega[index[~seen[index]]]],
            "rms_rel_omega_std": float(np.sqrt(np.mean(rel[hit] ** 2))) if hit.size else None,
            "median_rel_omega_std": float(np.median(rel[hit])) if hit.size else None}


def rank_key(row: dict[str, Any]) -> tuple[int, float]:
    """Order of ranking rows: fewest target modes missed, then least RMS."""
    return len(row["missed"]), np.inf if row["rms_rel_omega_std"] is None else row["rms_rel_omega_std"]


def rank_drives(model: Model, test: TestSpec, sensors: list[tuple[int, str, str]], drives: list[tuple[int, str]],
                target_modes: int | None = None, targets: list[float] | None = None) -> dict[str, Any]:
    """The ``drives`` section of a plan: every candidate excitation point of
    ``test``'s impulse scored on the channels ``sensors`` (node, dir,
    quantity), best first (module docstring); ``targets`` (rad/s, a layout's
    target modes) replace the target modes' choice."""
    impulse = the_impulse(test)
    base = fd.decay(model, test)
    seen, rel = point_bounds(model, base, impulse.impulse, drives, sensor_channels(model, test, sensors), {})
    index = target_index(base, rel, target_modes, targets)
    ranking = sorted((score_row(p, s, r, index, base.omega) for p, s, r in zip(drives, seen, rel)), key=rank_key)
    return {"candidates": len(drives), "impulse": float(impulse.impulse),
            "target_modes": [float(w) for w in base.omega[index]],
            "chosen": [ranking[0]["node"], ranking[0]["dir"]],
            "sensors": [list(s) for s in sensors], "ranking": ranking}
