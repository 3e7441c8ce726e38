"""The sensor records a modal identification works on, and whether they are
stationary. Imports only the identifier's errors and trace types and the
response quantities."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from structbench.models.channels import QUANTITIES as RESPONSES

from ..errors import IdentificationError
from ..io.traces import Channel, Trace
from .close_pairs import FREE_KINDS
from .ssi.covariance import is_free_decay

QUANTITIES = ("auto", *(q for q in RESPONSES if q != "force"))


def sensor_records(traces: Sequence[Trace], quantity: str) -> tuple[list[np.ndarray], list[Channel], float]:
    """Per trace the outputs (m, n), the channels (of the first trace, sorted
    by (node, direction)) and dt s. ``quantity``: every sensor of that
    quantity; ``auto``: at every sensor location (node, direction) one
    channel, its displacement, else velocity, else acceleration, so that a
    run whose locations carry different quantities uses them all (each
    channel is scaled by its RMS before the covariances, and the poles are
    the same whatever the quantity). One sensor is enough."""
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
    return records, channels, first.dt


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
