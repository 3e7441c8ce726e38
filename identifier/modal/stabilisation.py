"""Stabilisation diagram and automatic mode selection.

A pole of order ``n`` is *stable* when the previous order (``n - step``) has
a pole with

    |omega_n - omega_{n-1}| / omega_n < freq_tol,
    |zeta_n - zeta_{n-1}| < zeta_tol (|zeta_n| + 0.002),
    MAC(phi_n, phi_{n-1}) > mac_min,

and its damping ratio is physically plausible, ``-0.02 < zeta < zeta_max``
(a small negative margin: undamped structures give zeta ~ 0 of either sign).
In a stationary record a mode is found by the poles stable within the
looser ``STATIONARY_LOOSE`` (2 % and 0.3, :meth:`Criteria.for_record`): its
covariances carry estimation noise of relative size about ``1 / sqrt(zeta
omega T)`` (``T`` s of record; the relative standard error of a random
response's damping estimate is of that size), so a mode's poles wander
between neighbouring orders by more than a free decay's do, and at 1 % and
0.1 a mode of a short record is stable at too few orders to be found
(docs/modal-method.md, twelfth round). A mode stable within the strict tolerances at enough
orders is then estimated from those poles alone (its estimates and
errors as before), while its support and share of stable orders count
all its poles; only a mode found through the loose ones alone is
estimated from them. The coherence, jackknife and spectral-peak tests
after clustering (:mod:`identifier.modal.support`) tell such a mode from a
cluster of covariance-noise poles, not these tolerances.
Stable poles are grouped into modes: poles within ``freq_tol`` of a cluster's
mean frequency and with MAC above ``mac_min`` to its shape join it, so
that two modes of nearly equal frequency but different shapes stay apart and
one shape never yields two modes. A cluster is a mode when its poles come
from at least ``min_fraction`` of the orders; its frequency and damping ratio
are the medians over all its stable poles, its shape that of the pole
nearest the median frequency among them. Its spread over the model
orders is that of its own poles: at each order the one stable pole of the
cluster nearest, in the s-plane, the median of them all. A lightly
damped mode's random response gives SSI of high order poles of its
covariances' estimation noise beside the mode's own, of its shape and
stable too, a few half-power bandwidths either side of it: within
``freq_tol`` they join its cluster, and their scatter is not the mode's. (Only the lower half of the orders
was tried, against noise poles at high orders; with 15 modes in random data
it biased mode 10 by -0.12 % over 20 realisations, coverage 0.55, while all
orders give -0.02 % and damping medians within 5.3 %.)

Two modes of one shape (MAC above ``mac_min``) within ``freq_tol`` are one
(the one of more support is kept). A mode of the shape of another within
``shadow`` (10 %) in frequency, supported by fewer than ``shadow_support``
(3/4) of its stable poles, is that mode's shadow and dropped: the
estimation noise of a strong mode's covariances gives poles of its own
shape beside it, stable only at the high orders (in 50 random structures:
at most 2/3 of their parent's support). Distinct modes of one shape at
the sensors are mostly further apart: spatially aliased modes (the ch5
beam's modes 12-15 on its 10 sensors are its modes 10-7 there; in the
damped beam's random response they have 0.37-0.52 of those modes'
support, as little as far shadows have) and, on two or three sensors,
modes whose shapes the sensors cannot tell apart (without the window, 6
such modes of two-sensor structures were lost in 100 random structures);
nearer, their support tells them apart (two modes 9 % apart on two
sensors, MAC 0.98: 41 and 49 stable poles). Fails when a mode is stable in
too few orders (very weak or very close to a stronger mode): it is then
not reported; a weak mode of a much stronger one's shape within 10 % is
taken for its shadow; and the shadow of a lone mode in a short random
record can lie further out (up to 50 % in the fuzz benchmark) and is then
reported.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from structbench.models.mac import mac

from .ssi.poles import Poles


STATIONARY_LOOSE = (0.02, 0.3)  # freq_tol, zeta_tol of the poles that find a mode of a stationary record


@dataclass(frozen=True)
class Criteria:
    """Stabilisation tolerances (see the module docstring)."""

    freq_tol: float = 0.01
    zeta_tol: float = 0.1
    mac_min: float = 0.95
    zeta_max: float = 0.2
    min_fraction: float = 0.3
    shadow: float = 0.1
    shadow_support: float = 0.75
    loose: tuple[float, float] | None = None  # (freq_tol, zeta_tol) of the poles that find a mode

    @classmethod
    def for_record(cls, stationary: bool, min_fraction: float) -> Criteria:
        """The criteria for a stationary record (modes found by poles stable
        within ``STATIONARY_LOOSE``, module docstring) or a free response."""
        return cls(min_fraction=min_fraction, loose=STATIONARY_LOOSE if stationary else None)


@dataclass(frozen=True)
class Mode:
    """One selected mode: its representative pole (order, index in that
    order's :class:`Poles`), the stable poles that support it ((order, index)
    pairs), those its estimates use (``used``, all of them), its own
    poles (``own``: one per order, :func:`one_per_order`; their scatter is
    the mode's spread over the orders) and its estimates, the medians
    over ``used``: ``omega`` rad/s, ``zeta``."""

    order: int
    index: int
    members: tuple[tuple[int, int], ...]
    used: tuple[tuple[int, int], ...]
    omega: float
    zeta: float
    own: tuple[tuple[int, int], ...]

    @property
    def support(self) -> int:
        return len(self.members)


def stable_flags(poles: list[Poles], criteria: Criteria) -> list[np.ndarray]:
    """Per order a boolean array (k,) marking the stable poles (the lowest
    order has none). Every pair of neighbouring orders at once (shapes of
    unit norm, as :func:`identifier.modal.ssi.poles.poles_at` gives them): the
    orders' poles padded to the largest count (NaN frequencies and zero
    shapes never pass)."""
    counts = np.array([p.omega.size for p in poles])
    width = max(int(counts.max()), 1)
    omega = np.full((len(poles), width), np.nan)
    zeta = np.full((len(poles), width), np.nan)
    shapes = np.zeros((len(poles), poles[0].shapes.shape[0], width), dtype=complex)
    for i, p in enumerate(poles):
        omega[i, :p.omega.size], zeta[i, :p.omega.size], shapes[i, :, :p.omega.size] = p.omega, p.zeta, p.shapes
    cur, prev = slice(1, None), slice(None, -1)
    with np.errstate(invalid="ignore"):
        dfreq = np.abs(omega[cur, :, None] - omega[prev, None, :]) / omega[cur, :, None]
        dzeta = np.abs(zeta[cur, :, None] - zeta[prev, None, :])
        close = ((dfreq < criteria.freq_tol)
                 & (dzeta < criteria.zeta_tol * (np.abs(zeta[cur])[:, :, None] + 0.002))
                 & (np.abs(np.swapaxes(shapes[cur].conj(), 1, 2) @ shapes[prev]) ** 2 > criteria.mac_min))
        ok = close.any(axis=2) & (zeta[cur] > -0.02) & (zeta[cur] < criteria.zeta_max)
    return [np.zeros(counts[0], dtype=bool)] + [row[:k] for row, k in zip(ok, counts[1:])]


def _clusters(poles: list[Poles], flags: list[np.ndarray], criteria: Criteria) -> list[list[tuple[int, int]]]:
    """Stable poles grouped by frequency (within ``freq_tol`` of the cluster's
    mean) and shape (MAC to the cluster's first pole above ``mac_min``); each
    cluster is a list of (order position, pole index). The poles come in
    ascending frequency, so a cluster whose mean is below ``w (1 - freq_tol)``
    can take no further pole: only the clusters from ``first`` on are tried."""
    stable = sorted(((poles[i].omega[j], i, j) for i, f in enumerate(flags) for j in np.flatnonzero(f)))
    clusters: list[list[tuple[int, int]]] = []
    sums: list[float] = []
    shapes: list[np.ndarray] = []
    first = 0
    for w, i, j in stable:
        phi = poles[i].shapes[:, j]
        best, best_mac = -1, criteria.mac_min
        for c in range(first, len(clusters)):
            mean = sums[c] / len(clusters[c])
            if mean <= w * (1 - criteria.freq_tol) and c == first:
                first += 1
            elif abs(w - mean) < criteria.freq_tol * w:
                value = abs(np.vdot(shapes[c], phi)) ** 2  # both of unit norm
                if value > best_mac:
                    best, best_mac = c, value
        if best < 0:
            clusters.append([(i, j)])
            sums.append(w)
            shapes.append(phi)
        else:
            clusters[best].append((i, j))
            sums[best] += w
    return clusters


def select_modes(poles: list[Poles], criteria: Criteria,
                 valid: Callable[[list[Mode]], list[bool]] | None = None) -> tuple[list[Mode], list[np.ndarray]]:
    """The modes (ascending frequency) and the stability flags per order
    (those that find modes: within ``criteria.loose`` when given);
    ``valid``: a further test every mode must pass before shadows are
    dropped (so that a mode it rejects shadows none), given all the
    candidate modes at once, one verdict each."""
    flags = stable_flags(poles, criteria)
    found = flags if criteria.loose is None else \
        stable_flags(poles, replace(criteria, freq_tol=criteria.loose[0], zeta_tol=criteria.loose[1]))
    need = max(2, int(np.ceil(criteria.min_fraction * (len(poles) - 1))))
    modes = []
    for c in _clusters(poles, found, criteria):
        if len({i for i, _ in c}) < need:
            continue
        strict = [(i, j) for i, j in c if flags[i][j]]
        used = strict if len({i for i, _ in strict}) >= need else list(c)  # estimated from the strict poles
        own = one_per_order(used, poles)
        omega = np.array([poles[i].omega[j] for i, j in used])
        zeta = np.array([poles[i].zeta[j] for i, j in used])
        middle = median(omega)
        i, j = used[int(np.argmin(np.abs(omega - middle)))]
        modes.append(Mode(poles[i].order, int(j), tuple((poles[a].order, int(b)) for a, b in c),
                          tuple((poles[a].order, int(b)) for a, b in used), middle, median(zeta),
                          tuple((poles[a].order, int(b)) for a, b in own)))
    if valid is not None:
        modes = [md for md, ok in zip(modes, valid(modes)) if ok]
    return _merge(sorted(modes, key=lambda md: md.omega), poles, criteria), found


def one_per_order(cluster: list[tuple[int, int]], poles: list[Poles]) -> list[tuple[int, int]]:
    """Of a cluster's stable poles ((order position, index) pairs), at each
    order the one nearest, in the s-plane, the pole of the median frequency
    and damping ratio of them all, ``s_med = omega_med (-zeta_med + i)``
    (rad/s; the distance ``|s - s_med|`` weighs a frequency and a decay
    rate alike): the mode's own pole there, not the covariance noise's
    poles beside it (see the module docstring); in the cluster's order."""
    omega = np.array([poles[i].omega[j] for i, j in cluster])
    zeta = np.array([poles[i].zeta[j] for i, j in cluster])
    w, z = median(omega), median(zeta)
    distance = np.hypot(omega - w, zeta * omega - z * w)
    best: dict[int, int] = {}
    for k, (i, _) in enumerate(cluster):
        if i not in best or distance[k] < distance[best[i]]:
            best[i] = k
    chosen = set(best.values())
    return [pair for k, pair in enumerate(cluster) if k in chosen]


def median(values: np.ndarray | list[float]) -> float:
    """The median of a few values: ``np.median``'s value (the mean of the
    two middle ones for an even count) without its per-call overhead."""
    v = np.sort(np.asarray(values, dtype=float))
    return float((v[(v.size - 1) // 2] + v[v.size // 2]) / 2)


def _pole(poles: list[Poles], mode: Mode) -> Poles:
    return next(p for p in poles if p.order == mode.order)


def _merge(modes: list[Mode], poles: list[Poles], criteria: Criteria) -> list[Mode]:
    """Modes in ascending frequency, each of one shape (MAC above
    ``mac_min``) and a mode of more support kept within ``freq_tol`` (the
    same mode, clustered twice) dropped, as is its shadow: within
    ``shadow`` and of less than ``shadow_support`` times its support."""
    if not modes:
        return modes
    shapes = np.column_stack([_pole(poles, md).shapes[:, md.index] for md in modes])
    same = mac(shapes, shapes) > criteria.mac_min
    omega = np.array([md.omega for md in modes])
    support = np.array([md.support for md in modes])
    kept: list[int] = []
    for i in np.argsort(-support, kind="stable"):  # the best supported first
        gap = np.abs(omega[i] - omega[kept]) / omega[kept]
        under = (gap < criteria.freq_tol) | ((gap < criteria.shadow)
                                             & (support[i] < criteria.shadow_support * support[kept]))
        if not np.any(same[i, kept] & under):
            kept.append(int(i))
    return [modes[i] for i in sorted(kept)]
