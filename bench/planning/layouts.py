"""Sensor layouts: K channels out of candidate ones for the modal method.

Candidates (``--candidates FILE``): TOML ``[[candidates]]`` entries as
campaign sensor entries (``nodes`` = list or ``"all"``, optional ``dirs``,
``quantities``), or CSV rows ``node,dir,quantity`` under that header
(docs/plan.md). Each candidate channel ``c`` carries the free-decay
Fisher information ``I_c = L_c^T Q L_c / sigma_c^2`` (2R, 2R) on the modes'
``(alpha_r, wd_r)`` (:mod:`.free_decay`), in relative units (each pair
divided by ``omega_r``), for the modes that every candidate together
determines to :data:`PRECISE` (relative omega standard error). Three
layouts of ``K`` channels, at most one per (node, direction) since the
modal identifier takes one channel per location:

* effective independence (Kammer 1991): from all candidates, repeatedly
  drop the one of least ``E_c = psi_c^T (Psi^T Psi)^-1 psi_c``, ``psi_c``
  (R,) the channel's modal amplitudes over its noise, ``|beta_cr| / sigma_c``
  (one at a time near the budget, in batches of 5 % far above it); ``E_c =
  1 - det(A - psi_c psi_c^T) / det(A)``, ``A = Psi^T Psi``. Once no more
  channels are left than modes (a budget below R), every ``E_c`` is 1 and
  the drop continues on the volume ``det(Psi Psi^T)`` of the kept rows:
  the channel of least distance ``d_c`` from the span of the others goes
  (``det`` loses the factor ``d_c^2``);
* D-optimal on the method's own information: greedy, the channel that most
  increases ``log det(sum I_c + eps I)``, then exchange passes (each chosen
  channel swapped for the best other while that improves), O(K C R^3) per pass
  (candidates screened by each mode's own block above a shortlist);
* targeted on the frequencies (:mod:`.targeted`): greedy and exchanges on
  the summed predicted ``var(omega_r) / omega_r^2`` of the lowest
  ``target_modes`` planned modes (default: every planned mode).

The ``criterion`` picks the layout written as a campaign file (default
``./<campaign>-plan-<test>.toml``): ``frequencies`` (default) the one of
least predicted RMS relative error of the target frequencies, ``d-optimal``
the one of largest ``log det``, ``effective-independence`` Kammer's.
Fails (:class:`UserError`) for least squares (it needs a response at every
DOF), an unreadable file, a candidate that is not a model DOF, or a budget
above the number of distinct locations, an unknown criterion, or target
modes outside 1..(planned modes).
"""
from __future__ import annotations

import csv
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models import Model
from structbench.models.errors import UserError

from . import free_decay as fd
from . import targeted as tg
from .campaign_files import test_campaign

RIDGE = 1e-9  # eps relative to the largest diagonal entry of the full candidate information
EXCHANGE_PASSES = 3
EFI_BATCH = 4  # effective independence drops one candidate at a time below this many times the budget
RANK_TOL = 1e-6  # singular values of psi below this share of the largest: directions not spanned (rounding)
CRITERIA = ("frequencies", "d-optimal", "effective-independence")
PRECISE = 0.005  # modes planned for: predicted omega std below this share of omega with every candidate measured


def read_candidates(path: str | Path, model: Model) -> list[tuple[int, str, str]]:
    """(node, dir, quantity) per candidate channel, in file order, duplicates dropped."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise UserError(f"{path}: cannot read ({err})", field="--candidates") from None
    out: list[tuple[int, str, str]] = []
    if path.suffix.lower() == ".csv":
        rows = list(csv.DictReader(text.splitlines()))
        if not rows or set(rows[0]) != {"node", "dir", "quantity"}:
            raise UserError(f"{path}: expected the header node,dir,quantity", field="--candidates")
        for i, row in enumerate(rows, start=2):
            try:
                out.append((int(row["node"]), row["dir"].strip(), row["quantity"].strip()))
            except (TypeError, ValueError):
                raise UserError(f"{path}:{i}: node must be an integer", field="--candidates") from None
    else:
        try:
            entries = tomllib.loads(text).get("candidates", [])
        except tomllib.TOMLDecodeError as err:
            raise UserError(f"{path}: {err}", field="--candidates") from None
        for i, e in enumerate(entries, start=1):
            if not isinstance(e, dict) or "nodes" not in e or "quantities" not in e:
                raise UserError(f"{path}: candidates[{i}] needs nodes and quantities", field="--candidates")
            dofs = [d for d in model.dofs if e["nodes"] == "all" or d[0] in e["nodes"]]
            dofs = [d for d in dofs if "dirs" not in e or d[1] in e["dirs"]]
            out += [(n, d, q) for n, d in dofs for q in e["quantities"]]
    for n, d, q in out:
        if q not in fd.ORDER:
            raise UserError(f"{path}: candidate quantity {q!r}; known: {', '.join(fd.ORDER)}", field="--candidates")
        try:
            model.dof_index(n, d)
        except Exception:
            raise UserError(f"{path}: candidate ({n}, {d!r}) is not a free DOF of {model.name}",
                            field="--candidates") from None
    return list(dict.fromkeys(out))


def candidate_information(model: Model, test, cands: list[tuple[int, str, str]], free: fd.Decay | None = None,
                          cache: dict[bytes, tuple[np.ndarray, np.ndarray]] | None = None) -> tuple[
                              np.ndarray, np.ndarray, fd.Decay]:
    """Per candidate the relative information (C, 2R, 2R) and ``psi`` (C, R),
    on the modes visible with every candidate measured and determined by
    them to :data:`PRECISE`, and those modes. ``free``: the free decay to
    plan on (default ``test``'s on ``model``; :mod:`.joint` moves the
    impulse); ``cache``: bases kept between calls (:func:`.free_decay.cached_bases`)."""
    d = fd.decay(model, test) if free is None else free
    rows = np.array([model.dof_index(n, di) for n, di, _ in cands])
    orders = np.array([fd.ORDER[q] for _, _, q in cands])
    ratio = np.array([test.noise.ratio(q) for _, _, q in cands])
    if not ratio.any():
        raise UserError("the test has no sensor noise on the candidate quantities", field="noise")
    beta = fd.amplitudes(d, rows, orders)
    gram, _ = fd.cached_bases(d, cache)
    sigma = fd.channel_sigma(beta, ratio, gram)
    seen = fd.visible(d, beta, sigma)
    d = fd.Decay(d.omega[seen], d.zeta[seen], d.A[seen], d.B[seen], d.shapes[:, seen], d.dt, d.m)
    beta = beta[:, seen]
    _, Q = fd.cached_bases(d, cache)
    info = fd.channel_information(beta, sigma, Q)
    rel = np.sqrt(fd.omega_zeta_covariance(d, info.sum(axis=0))[:, 0, 0]) / d.omega
    keep = rel < PRECISE
    if not keep.all():  # plan for the modes the full candidate set determines well
        d = fd.Decay(d.omega[keep], d.zeta[keep], d.A[keep], d.B[keep], d.shapes[:, keep], d.dt, d.m)
        beta = beta[:, keep]
        _, Q = fd.cached_bases(d, cache)
        info = fd.channel_information(beta, sigma, Q)
    scale = np.repeat(d.omega, 2)  # (alpha, wd) / omega: relative units
    info *= scale[None, :, None] * scale[None, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        psi = np.where(sigma[:, None] > 0, np.linalg.norm(beta, axis=2) / sigma[:, None], 0.0)
    return info, psi, d


def _logdet(J: np.ndarray) -> float:
    sign, value = np.linalg.slogdet(J)
    return float(value) if sign > 0 else -np.inf


def _span_distances(P: np.ndarray) -> np.ndarray:
    """Distance (C,) of each row of ``P`` (C, R), C <= R, from the span of
    the other rows: ``|p_c - p_c O_c^+ O_c|``, ``O_c`` the others (C - 1, R),
    its singular values below :data:`RANK_TOL` of the largest dropped: rows
    dependent but for rounding (mirror-image channels of a symmetric
    structure) are dependent, distance about 0, not a rounding-made span."""
    C = P.shape[0]
    others = np.broadcast_to(P, (C,) + P.shape)[~np.eye(C, dtype=bool)].reshape(C, C - 1, P.shape[1])
    proj = np.einsum("cr,crj,cjs->cs", P, np.linalg.pinv(others, rcond=RANK_TOL), others)
    return np.linalg.norm(P - proj, axis=1)


def effective_independence(psi: np.ndarray, locations: np.ndarray, k: int) -> list[int]:
    """Kammer's effective independence: indices (ascending) of ``k`` of the C
    candidates kept, at most one per location (of a shared location the weaker
    channels go first). ``psi`` (C, R), ``locations`` (C,) ids. While over
    :data:`EFI_BATCH` x ``k`` remain, the lowest 5 % go at once; at most R
    left, the least span distance goes (module docstring). Scores within
    :data:`~.targeted.TIE` of their scale (1 for ``E_c``, the largest row norm
    for distances) count as equal and the lower index goes first, so that
    rounding-level differences of ``psi`` leave the layout as is."""
    alive = np.ones(psi.shape[0], bool)
    while alive.sum() > k:
        idx = np.flatnonzero(alive)
        if idx.size > psi.shape[1]:  # E_c in [0, 1]
            A_inv = np.linalg.pinv(psi[idx].T @ psi[idx], rcond=RANK_TOL**2)
            crit, scale = np.einsum("cr,rs,cs->c", psi[idx], A_inv, psi[idx]), 1.0
        else:  # every E_c is 1 here; distances at most the largest row norm
            crit, scale = _span_distances(psi[idx]), float(np.max(np.linalg.norm(psi[idx], axis=1)))
        loc, counts = np.unique(locations[idx], return_counts=True)
        shared = np.isin(locations[idx], loc[counts > 1])  # the identifier uses one per location
        rank = np.empty(idx.size, dtype=int)
        rank[tg.tied_order(crit, tg.TIE * scale)] = np.arange(idx.size)
        drop = max(1, idx.size // 20) if idx.size > EFI_BATCH * k else 1
        alive[idx[np.lexsort((rank, ~shared))[:min(drop, idx.size - k)]]] = False
    return np.flatnonzero(alive).tolist()


def d_optimal(info: np.ndarray, locations: np.ndarray, k: int, eps: float) -> list[int]:
    """Greedy D-optimal choice of ``k`` candidates (one per location), then
    exchanges. Above :data:`~.targeted.SHORTLIST` allowed candidates a step
    ranks them by the decoupled-mode ``sum_r log det`` of each mode's 2 x 2
    block of ``J + I_c`` (O(C R)) and takes the exact ``log det`` of the best
    ``SHORTLIST``."""
    blocks = tg.mode_blocks(info)

    def best(J: np.ndarray, allowed: np.ndarray) -> tuple[int, float]:
        ok = np.flatnonzero(allowed)
        if ok.size > tg.SHORTLIST:
            pqs = tg.mode_blocks(J)[None] + blocks[ok]
            with np.errstate(divide="ignore", invalid="ignore"):
                approx = np.sum(np.log(pqs[..., 0] * pqs[..., 2] - pqs[..., 1] ** 2), axis=1)
            ok = ok[tg.tied_order(-np.nan_to_num(approx, nan=-np.inf), tg.TIE)[:tg.SHORTLIST]]
            ok = np.sort(ok)
        sign, val = np.linalg.slogdet(J[None] + info[ok])
        val = np.where(sign > 0, val, -np.inf)
        i = int(tg.tied_order(-val, tg.TIE)[0])  # log det: TIE absolute, a relative TIE on det
        return int(ok[i]), float(val[i])

    return tg.greedy_exchange(info, eps * np.eye(info.shape[1]), locations, k, best,
                              lambda val, J: val > _logdet(J) + 1e-9, EXCHANGE_PASSES)


def evaluate(info: np.ndarray, d: fd.Decay, chosen: list[int], eps: float,
             targets: int | None = None) -> dict[str, Any]:
    """``log det`` of the layout's relative information, its median predicted
    relative omega standard error over the planned modes and the RMS of it
    over the lowest ``targets`` (default all) planned modes
    (``sqrt(f / T)`` of :mod:`.targeted`)."""
    J = info[chosen].sum(axis=0) + eps * np.eye(info.shape[1])
    scale = np.repeat(d.omega, 2)
    cov = fd.omega_zeta_covariance(d, J / np.outer(scale, scale))
    rel = np.sqrt(cov[:, 0, 0]) / d.omega
    count = d.omega.size if targets is None else targets
    return {"log_det": _logdet(J), "median_rel_omega_std": float(np.median(rel)),
            "rms_rel_omega_std": float(np.sqrt(np.mean(rel[:count] ** 2)))}


def plan_layout(model: Model, specs, method: str, candidates: str | Path, k: int, campaign: Path, test: str,
                out: str | Path | None = None, criterion: str = "frequencies",
                target_modes: int | None = None) -> dict[str, Any]:
    """The ``layout`` section of a plan (the three layouts, the one the
    ``criterion`` chooses and the campaign file written with it)."""
    if criterion not in CRITERIA:
        raise UserError(f"no layout criterion {criterion!r}; criteria: {', '.join(CRITERIA)}", field="--criterion")
    if method != "modal":
        raise UserError(f"sensor layouts are planned for the modal method; {method} needs a response at every "
                        "DOF", field="--candidates")
    if len(specs) != 1:
        raise UserError("a layout is planned for one test", field="--test")
    cands = read_candidates(candidates, model)
    ids: dict[tuple[int, str], int] = {}
    locations = np.array([ids.setdefault((n, d), len(ids)) for n, d, _ in cands])
    if not 1 <= k <= np.unique(locations).size:
        raise UserError(f"must be between 1 and the {np.unique(locations).size} candidate locations",
                        field="--sensors")
    info, psi, d = candidate_information(model, specs[0], cands)
    if info.shape[1] == 0:
        raise UserError("no mode of the test is visible at the candidates", field="--candidates")
    planned = d.omega.size
    targets = planned if target_modes is None else int(target_modes)
    if not 1 <= targets <= planned:
        raise UserError(f"must be between 1 and the {planned} planned modes", field="--target-modes")
    eps = RIDGE * float(np.max(np.diag(info.sum(axis=0))))
    layouts = {"frequencies": tg.targeted(info, d.zeta, locations, k, eps, targets),
               "d-optimal": d_optimal(info, locations, k, eps),
               "effective-independence": effective_independence(psi, locations, k)}
    rows = {name: evaluate(info, d, idx, eps, targets) | {"sensors": [list(cands[i]) for i in sorted(idx)]}
            for name, idx in layouts.items()}
    if criterion == "frequencies":
        chosen = min(rows, key=lambda name: rows[name]["rms_rel_omega_std"])
    elif criterion == "d-optimal":
        chosen = max(rows, key=lambda name: rows[name]["log_det"])
    else:
        chosen = criterion
    target = Path(out) if out is not None else Path.cwd() / f"{campaign.stem}-plan-{test}.toml"
    target.write_text(test_campaign(campaign, test, sensors=[tuple(s) for s in rows[chosen]["sensors"]],
                                    only=False), encoding="utf-8")
    return {"candidates": len(cands), "budget": k, "criterion": criterion,
            "target_modes": [float(w) for w in d.omega[:targets]], "chosen": chosen,
            "sensors": rows[chosen]["sensors"], "campaign": str(target), "layouts": rows,
            "modes_planned": [float(w) for w in d.omega]}
