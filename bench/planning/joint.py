"""Sensors and excitation point chosen together (``--candidates`` with ``--drives``).

A free decay of one impulse ``I``: which of the candidate points ``j`` (D,)
to strike and which ``K`` of the candidate channels (C,) to record, for the
least predicted RMS relative error of the target frequencies. A pair
``(j, S)`` is scored as :mod:`.drives` scores a point: the modal bound of
the test driven at ``j`` (modal initial velocities ``I phi_jr``) through
the channels ``S`` alone (the modes they see, their information ``J =
sum_c L_c^T Q L_c / sigma_c^2``; :mod:`.free_decay`), key = (target modes
not seen, ``sqrt(mean_r var(omega_r) / omega_r^2)`` over those seen),
smaller better; what ``plan --method modal`` predicts for the written
campaign.

Target modes: the lowest ``target_modes`` (default all) of the modes some
candidate point determines to :data:`~.layouts.PRECISE` in omega with
every candidate channel measured (the point ranking's rule with all
candidates as sensors). They are the same for every pair, so pairs at
different points compare on the same frequencies.

Search (the pair space has ``D x binom(C, K)`` members). A point's own
layout ``S_j`` is the targeted layout (:mod:`.targeted`: greedy and
exchanges on ``tr(G^T J^-1 G)`` over the target modes the point's full
candidate set determines, on :func:`.layouts.candidate_information` of the
decay driven at ``j``).

1. alternation from the sequential pair (``start``: the layout chosen at
   the test's own point, scored at every point, at the best one for it):
   the best point for the layout, then that point's own layout, while the
   key drops (every move strictly lowers it: it ends);
2. the points in order of their floor, the key with every candidate
   channel measured: while a point's floor beats the best pair so far (and
   for at most :data:`SCREEN` points), its own layout is scored there. The
   floor bounds every layout's key at that point from below (more channels,
   more information) but for the modes a layout leaves unseen, which it no
   longer carries as nuisance terms;
3. alternation from the best pair.

Every pair evaluated is kept; per point the best layout found there
(``ranking``, best first, each row with its ``sensors``). The pair chosen
is at least as good by the bound as the sequential one (it is among those
evaluated) and a local optimum of the alternation; no guarantee of the
global one (``tests/test_plan_joint.py`` checks it against exhaustive
search on a small beam). Ties: RMS values within :data:`~.targeted.TIE`
(relative) are equal, the earlier point in the file first, and a move
needs a drop beyond it (mirror-image points of a symmetric structure
differ by rounding). Cost: the floors (O(D C R^3)), up to
:data:`SCREEN` targeted layouts plus one per alternation move (each O(K C
R^3) per pass), and per alternation step one layout scored at every point
(O(D K R^3)).

Fails (:class:`UserError`) as :func:`.drives.rank_drives` and
:func:`.layouts.plan_layout` do (not one impulse, no noise, target modes
outside 1..(modes some point determines)).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from structbench.harness.test_entries import TestSpec
from structbench.models import Model

from . import drives as dv
from . import free_decay as fd
from . import targeted as tg
from .layouts import RIDGE, candidate_information, read_candidates

Layout = tuple[tuple[int, str, str], ...]
MAX_STEPS = 50  # alternation steps per start (each strictly lowers the key; a guard, not a tuning constant)
SCREEN = 16  # step 1 plans a layout for at most this many points, least floor first


def _layout_at(model: Model, test: TestSpec, base: fd.Decay, impulse: float, point: tuple[int, str],
               cands: list[tuple[int, str, str]], locations: np.ndarray, k: int, targets: np.ndarray,
               cache: dict[bytes, tuple[np.ndarray, np.ndarray]]) -> Layout | None:
    """The targeted layout (sorted channels) of ``k`` candidates for the decay
    driven at ``point``, on the target modes (rad/s) its candidates determine;
    None if they determine none of them."""
    info, _, d = candidate_information(model, test, cands, free=dv.driven(base, model, point, impulse),
                                       cache=cache)
    modes = np.flatnonzero(np.isclose(d.omega[:, None], targets[None, :], rtol=1e-9).any(axis=1))
    if not modes.size:
        return None
    eps = RIDGE * float(np.max(np.diag(info.sum(axis=0))))
    return tuple(sorted(cands[i] for i in tg.targeted(info, d.zeta, locations, k, eps, 0, modes=modes)))


def better(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Row ``a`` beats row ``b``: fewer target modes missed, or as many and an
    RMS lower by more than :data:`~.targeted.TIE` (relative: rounding-level
    differences, such as mirror-image points of a symmetric structure, are ties)."""
    (ma, ra), (mb, rb) = dv.rank_key(a), dv.rank_key(b)
    return ma < mb or (ma == mb and ra < rb * (1 - tg.TIE))


def ordered(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``rows`` best first by :func:`.drives.rank_key`, RMS values within
    :data:`~.targeted.TIE` (relative) of each other tied and kept in their order."""
    if not rows:
        return []
    missed = np.array([dv.rank_key(r)[0] for r in rows])
    rms = np.array([dv.rank_key(r)[1] for r in rows])
    finite = rms[np.isfinite(rms)]
    position = np.empty(len(rows), dtype=int)
    position[tg.tied_order(rms, tg.TIE * (float(finite.min()) if finite.size else 1.0))] = np.arange(len(rows))
    return [rows[i] for i in np.lexsort((position, missed))]


class _Pairs:
    """Scores of (point, layout) pairs, memoised; per point the best seen."""

    def __init__(self, model: Model, test: TestSpec, base: fd.Decay, impulse: float,
                 drives: list[tuple[int, str]], index: np.ndarray,
                 cache: dict[bytes, tuple[np.ndarray, np.ndarray]]) -> None:
        self.model, self.test, self.base, self.impulse = model, test, base, impulse
        self.drives, self.index, self.cache = drives, index, cache
        self.rows: dict[tuple[tuple[int, str], Layout], dict[str, Any]] = {}
        self.best: dict[tuple[int, str], dict[str, Any]] = {}

    def score(self, points: list[tuple[int, str]], layout: Layout) -> list[dict[str, Any]]:
        """Ranking rows (with ``sensors``) of ``layout`` at each of ``points``."""
        todo = [p for p in points if (p, layout) not in self.rows]
        if todo:
            channels = dv.sensor_channels(self.model, self.test, list(layout))
            seen, rel = dv.point_bounds(self.model, self.base, self.impulse, todo, channels, self.cache)
            for p, s, r in zip(todo, seen, rel):
                row = dv.score_row(p, s, r, self.index, self.base.omega) | {"sensors": [list(c) for c in layout]}
                self.rows[(p, layout)] = row
                if p not in self.best or better(row, self.best[p]):
                    self.best[p] = row
        return [self.rows[(p, layout)] for p in points]

    def best_point(self, layout: Layout) -> dict[str, Any]:
        """The row of the candidate point where ``layout`` scores best (first in file order on ties)."""
        return ordered(self.score(self.drives, layout))[0]


def _alternate(pairs: _Pairs, point: tuple[int, str], layout: Layout,
               own_layout: Callable[[tuple[int, str]], Layout | None]) -> int:
    """Best point for the layout, then the point's own layout, while the
    key drops; the number of moves made."""
    moves = 0
    now = pairs.score([point], layout)[0]
    for _ in range(MAX_STEPS):
        moved = False
        row = pairs.best_point(layout)
        if better(row, now):
            point, now, moved = (row["node"], row["dir"]), row, True
        own = own_layout(point)
        if own is not None and own != layout:
            row = pairs.score([point], own)[0]
            if better(row, now):
                layout, now, moved = own, row, True
        if not moved:
            break
        moves += 1
    return moves


def joint_plan(model: Model, test: TestSpec, cands: list[tuple[int, str, str]], locations: np.ndarray, k: int,
               drives: list[tuple[int, str]], start: list[tuple[int, str, str]],
               target_modes: int | None = None) -> dict[str, Any]:
    """The ``drives`` section of a joint plan: the candidate points ranked
    each with the best layout of ``k`` of ``cands`` (``locations`` (C,)
    their location ids, one channel per location) found for it, ``chosen``
    and ``sensors`` the best pair, ``sequential`` the pair of the layout
    ``start`` (chosen at the test's own point) at its best point, all on the
    same target modes (module docstring)."""
    impulse = dv.the_impulse(test).impulse
    base = fd.decay(model, test)
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
    seen_all, rel_all = dv.point_bounds(model, base, impulse, drives, dv.sensor_channels(model, test, cands), cache)
    index = dv.target_index(base, rel_all, target_modes, None)
    targets = base.omega[index]
    pairs = _Pairs(model, test, base, impulse, drives, index, cache)
    layouts: dict[tuple[int, str], Layout | None] = {}

    def own_layout(p: tuple[int, str]) -> Layout | None:
        if p not in layouts:
            seen = np.any(rel_all[drives.index(p)][index] < np.inf)
            layouts[p] = _layout_at(model, test, base, impulse, p, cands, locations, k, targets,
                                    cache) if seen else None
        return layouts[p]

    first = tuple(sorted(tuple(s) for s in start))
    sequential = pairs.best_point(first)  # scores the start layout at every point
    moves = _alternate(pairs, (sequential["node"], sequential["dir"]), first, own_layout)
    floor = ordered([dv.score_row(p, s, r, index, base.omega) for p, s, r in zip(drives, seen_all, rel_all)])
    for row in floor[:SCREEN]:  # every channel measured: no layout there does better (nearly: see the docstring)
        top = ordered(list(pairs.best.values()))[0]
        if not better(row, top):
            break
        p = (row["node"], row["dir"])
        if own_layout(p) is not None:
            pairs.score([p], own_layout(p))
    top = ordered([pairs.best[p] for p in drives])[0]
    moves += _alternate(pairs, (top["node"], top["dir"]), tuple(tuple(s) for s in top["sensors"]), own_layout)
    ranking = ordered([pairs.best[p] for p in drives])
    return {"candidates": len(drives), "impulse": float(impulse), "joint": True,
            "target_modes": [float(w) for w in targets], "chosen": [ranking[0]["node"], ranking[0]["dir"]],
            "sensors": ranking[0]["sensors"], "ranking": ranking, "sequential": sequential,
            "layouts_planned": sum(v is not None for v in layouts.values()), "pairs_scored": len(pairs.rows),
            "alternation_moves": moves}


def joint_section(model: Model, test: TestSpec, candidates: str, k: int, drives: list[tuple[int, str]],
                  start: list[tuple[int, str, str]], target_modes: int | None = None) -> dict[str, Any]:
    """:func:`joint_plan` for the candidates file ``candidates`` (read as
    ``--candidates``: one channel per (node, dir) location in a layout)."""
    cands = read_candidates(candidates, model)
    ids: dict[tuple[int, str], int] = {}
    locations = np.array([ids.setdefault((n, d), len(ids)) for n, d, _ in cands])
    return joint_plan(model, test, cands, locations, k, drives, start, target_modes)
