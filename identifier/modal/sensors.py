"""The sensor records a modal identification works on, and whether they are
stationary. Imports only the identifier's errors and trace types and the
response quantities."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import stats

from structbench.models.channels import QUANTITIES as RESPONSES

from ..errors import IdentificationError
from ..io.traces import Channel, Trace
from .close_pairs import FREE_KINDS
from .ssi.covariance import is_free_decay

QUANTITIES = ("auto", *(q for q in RESPONSES if q != "force"))
CLIPPED_P = 1e-6  # chance that a quantised channel's extreme value gathers as many samples without clipping
TIES = 3  # samples at the extreme value of a continuous channel that only clipping gives
SOME = 4096  # samples, evenly spread, whose distinct values tell a continuous channel from a quantised one


def sensor_records(traces: Sequence[Trace], quantity: str
                   ) -> tuple[list[np.ndarray], list[Channel], float, list[str]]:
    """Per trace the outputs (m, n), the channels (of the first trace, sorted
    by (node, direction)), dt s and a note for each channel left out
    (:func:`usable`). ``quantity``: every sensor of that quantity; ``auto``:
    at every sensor location (node, direction) one channel, its
    displacement, else velocity, else acceleration, so that a run whose
    locations carry different quantities uses them all (each channel is
    scaled by its RMS before the covariances, and the poles are the same
    whatever the quantity). One sensor is enough."""
    if quantity not in QUANTITIES:
        raise IdentificationError(f"unknown quantity {quantity!r}; known: {', '.join(QUANTITIES)}",
                                  field="quantity")
    first = traces[0]
    if quantity == "auto":
        best: dict[tuple[int, str], Channel] = {}
        for q in reversed(QUANTITIES[1:]):  # the preferred quantity last: it wins
            best.update((c.dof, c) for c in first.select(q))
        channels = [best[dof] for dof in sorted(best)]
    else:
        channels = first.select(quantity)
    if not channels:
        raise IdentificationError(f"{first.path.name}: modal identification needs at least 1 "
                                  f"{quantity if quantity != 'auto' else 'motion'} sensor, found none",
                                  field="channels")
    records = []
    for trace in traces:
        here = [trace.channel(c.quantity, c.node, c.direction) for c in channels]
        bad = [c.name for c in here if not np.all(np.isfinite(c.data))]
        if bad:
            raise IdentificationError(f"{trace.path.name}: channel {bad[0]} holds NaN or infinite samples",
                                      field=bad[0])
        if not np.isclose(trace.dt, first.dt, rtol=1e-9):
            raise IdentificationError(f"{trace.path.name}: dt {trace.dt} s differs from {first.dt} s",
                                      field="dt")
        records.append(np.vstack([c.data for c in here]))
    if not any(np.ptp(y, axis=1).max() > 0 for y in records):
        kinds = " and ".join(sorted({c.quantity for c in channels}))
        raise IdentificationError(f"{first.path.name}: every {kinds} channel is constant in every trace: "
                                  f"no response to identify", field="channels")
    keep, notes = usable(records, [c.name for c in channels])
    if not keep:
        raise IdentificationError(f"{first.path.name}: no channel carries a response to identify: "
                                  + "; ".join(n.removesuffix(": left out") for n in notes), field="channels")
    return [y[keep] for y in records], [channels[i] for i in keep], first.dt, notes


def usable(records: Sequence[np.ndarray], names: Sequence[str], tol: float = 1e-12) -> tuple[list[int], list[str]]:
    """The channels (indices into the rows of each record (m, n)) that carry a response of their own, and
    a note for each one left out: constant in every record (a dead or unplugged sensor); clipped in any
    (:func:`clipped`: an overloaded sensor or amplifier, whose harmonics and intermodulation would pass
    for modes); or a copy of an earlier kept channel up to scale and offset (``1 - |r| <= tol``, ``r`` the
    correlation of the records' centred samples; a channel logged twice, which makes the outputs'
    covariance singular)."""
    centred = [y - y.mean(axis=1, keepdims=True) for y in records]
    gram = sum(c @ c.T for c in centred)
    power = np.diag(gram)
    dead = np.all([np.ptp(y, axis=1) == 0 for y in records], axis=0)
    pile = np.max([clipped(y) for y in records], axis=0)
    keep: list[int] = []
    notes: list[str] = []
    for j, name in enumerate(names):
        if dead[j]:
            notes.append(f"channel {name} is constant in every trace: left out")
            continue
        if pile[j]:
            notes.append(f"channel {name} is clipped ({pile[j]} samples at its extreme value): left out")
            continue
        twin = [i for i in keep if 1 - abs(gram[i, j]) / np.sqrt(power[i] * power[j]) <= tol]
        if twin:
            notes.append(f"channel {name} repeats channel {names[twin[0]]} (correlation 1): left out")
            continue
        keep.append(j)
    return keep, notes


def clipped(y: np.ndarray, level: float = CLIPPED_P) -> np.ndarray:
    """Per channel of ``y`` (m, n) the samples piled up at its largest or smallest value, 0 where there is
    no pile-up (m,). Without clipping the samples at the extreme value ``c_1`` and at the next one inward
    ``c_2`` are few and alike: one each in a continuous record (over 90 % of ``SOME`` of its samples,
    evenly spread, distinct); in a quantised one ``c_1 <= c_2`` on average where the tail falls outward,
    ``c_1`` up to 1.4 ``c_2`` at a sinusoid's crest (the arcsine law); clipping piles every sample beyond
    the level onto it. Clipped where ``c_1 >= TIES`` in a continuous record, else where
    ``P(Binomial(c_1 + c_2, 2/3) >= c_1) < level``, on either side. A leading or trailing run of ``TIES``
    samples or more of one value (a record at rest before or after) is not counted."""
    n = y.shape[1]
    lead, trail = (np.where(np.all(x == x[:, :1], axis=1), n, np.argmax(x != x[:, :1], axis=1))[:, None]
                   for x in (y, y[:, ::-1]))  # lengths (m, 1) of the leading and trailing runs of one value
    k = np.arange(n)
    run = (k < lead) & (lead >= TIES) | (k >= n - trail) & (trail >= TIES)
    some = np.sort(y[:, ::max(1, n // SOME)], axis=1)  # the distinct share of evenly spread samples
    continuous = 1 + np.count_nonzero(np.diff(some, axis=1), axis=1) >= 0.9 * some.shape[1]
    out = np.zeros(y.shape[0], dtype=int)
    for side in (y, -y):
        side = np.where(run, -np.inf, side)
        top = side.max(axis=1, keepdims=True)
        c1 = np.sum(side == top, axis=1)
        inner = np.where(side < top, side, -np.inf).max(axis=1, keepdims=True)
        c2 = np.sum(side == inner, axis=1)
        pile = np.where(continuous, c1 >= TIES, stats.binom.sf(c1 - 1, c1 + c2, 2 / 3) < level)
        pile &= np.isfinite(top[:, 0])  # not every sample in a run
        out = np.where(pile, np.maximum(out, c1), out)
    return out


def free_response(traces: Sequence[Trace], records: Sequence[np.ndarray]) -> tuple[bool, bool]:
    """(decay, free): every record decays (:func:`is_free_decay`); or it does,
    or every trace is labelled a free response (impulse, initial). A record
    that is not free is stationary."""
    decay = all(is_free_decay(y) for y in records)
    return decay, decay or all(str(t.excitation_attrs.get("kind", "")) in FREE_KINDS for t in traces)


def channels_quantity(channels: Sequence[Channel]) -> str:
    """The channels' quantity, or ``mixed`` (each sensor's shape entry is then in its own quantity)."""
    kinds = {c.quantity for c in channels}
    return kinds.pop() if len(kinds) == 1 else "mixed"
