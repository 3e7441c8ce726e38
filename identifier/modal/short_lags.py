"""A second pass over a stationary record with a quarter of the block rows: the broad modes long lags hide.

The first pass sizes its Hankel matrix for the record's slowest covariances
(:mod:`.ssi.design`: lags that span a quarter period of the lowest frequency
carrying power, as long as they stand out of their estimation noise). A
lightly damped low mode thus sets lags of tens of its periods, while a
well-damped or high mode's covariance ``R_l ~ exp(-zeta omega l dt)`` is gone
after a few decay times: past them its block rows hold only estimation
noise, and SSI spends its orders on that noise's poles around the mode
(several light poles over one broad peak, each failing the support tests)
instead of fitting the mode once. The pass identifies the records again by
the same steps 0-5 with ``p / 4`` block rows (``p`` the first pass's; the
columns still reach the quarter period, :func:`.ssi.design.block_sizes`)
and adds a mode found there when

- its temporal coherence reaches the first pass's bar ``coherent`` without
  that pass's exemption for modes stable at most orders (as the deflated
  pass, :mod:`.deflation`), and
- no reported mode lies within ``NEAR`` (5 %) of it (such a mode is the
  reported one, not listed again: the shorter lags bias a mode both passes
  see by up to a few per cent, and it must not come twice; the pass drops
  those candidates before its own tests, ``beside``, which thus lack them
  as neighbours: the peak test below has them) nor within the
  record's resolution plus both half-power half-widths or the reported
  mode's 95 % interval (:func:`.deflation.resolved`), and
- the record's spectrum holds its peak: :func:`.peak_test.peak_lr` at its
  own damping, every reported and added mode a neighbour, in the summed
  periodogram or in one channel's in both halves of the record
  (:func:`.peak_test.peak_in_any`: a mode that one low-noise sensor sees is
  lost in the sum), gives a p-value under ``peak_test.ALPHA`` (0.01, with
  its Bonferroni factors over the record's half-power bands, the channels
  and the two tests). A record taken for stationary that is not (a
  free decay whose light low modes hardly decay in it, its higher modes
  dying out at its start) gives the pass covariance-noise poles whose
  coherence passes; they have no peak of their own in the sum, and in one
  channel the dying mode's skirt, distorted by that channel's cross terms,
  fits a broad peak only in the half of the record that holds it.

Its frequency, damping, shape and their standard errors are the second
pass's (the same jackknife and bias terms). Skipped (``details["short_lags"]``
says why) for free responses, when the caller fixed ``block_rows``, when
``p / 4`` is under ``MIN_ROWS``, or when the pass refuses the records;
``short_lags="off"`` (:func:`identifier.modal.identify`) runs no pass.
Fails (misses the mode) where the first pass's lags were right for it and
it is weak beside a stronger mode within 5 %, or where its peak is within
the scatter of a stronger neighbour's skirt.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..errors import IdentificationError
from ..io.results import Identification
from ..io.traces import Trace
from .deflation import admitted, merged
from .peak_test import ALPHA, peak_in_any

SHORTER = 4  # the pass's block rows: the first pass's over this
MIN_ROWS = 8  # least block rows of the pass
NEAR = 0.05  # no reported mode within this relative distance of an added one


def extend(traces: Sequence[Trace], records: list[np.ndarray], dt: float, result: Identification,
           fixed_rows: bool, run: Callable[..., Identification], coherent: float) -> Identification:
    """``result`` of the stationary ``traces`` (their mean-removed sensor
    records (m, n_i) sampled at ``dt`` s) with the modes its short-lag pass
    finds added (module docstring); ``details["short_lags"]`` says what the
    pass did, ``details["rejected"]`` gains what it saw and rejected.
    ``run(traces, **options)``: the identification to repeat; ``fixed_rows``:
    the caller gave the block rows (then nothing is done)."""
    if fixed_rows or not result.details["input_output"]["input"].startswith("off"):
        return result
    rows = int(result.details["block_rows"]) // SHORTER
    info: dict = {"block_rows": rows, "added": [False] * len(result.omega)}
    result.details["short_lags"] = info
    if rows < MIN_ROWS:
        info["skipped"] = f"{rows} block rows (needs {MIN_ROWS})"
        return result
    try:
        second = run(traces, block_rows=rows, beside=tuple(result.omega))
    except IdentificationError as err:
        info["skipped"] = f"the short-lag pass refused the records: {err}"
        return result
    new = peaked(records, dt, result, second, admitted(second, result, coherent, "short-lag pass"))
    if not new:
        return result
    shapes = np.array([second.mode_shapes_complex[j] for j in new]) @ np.array([1.0, 1j])  # (k', m)
    return merged(result, second, new, shapes.T, "short_lags", [second.mode_shapes_std[j] for j in new])


def peaked(records: list[np.ndarray], dt: float, result: Identification, second: Identification,
           new: list[int]) -> list[int]:
    """Those of ``second``'s modes ``new`` whose spectral peak passes
    :func:`.peak_test.peak_in_any` at their own damping (p-value under
    ``peak_test.ALPHA``; every reported and added mode a neighbour) in the
    records (m, n_i) sampled at ``dt`` s; the others join
    ``result.details["rejected"]``."""
    if not new:
        return new
    k = len(result.omega)
    omega = np.concatenate([result.omega, [second.omega[j] for j in new]])
    zeta = np.concatenate([result.damping, [second.damping[j] for j in new]])
    p = peak_in_any(records, dt, omega, zeta, list(range(k, k + len(new))))
    kept = [j for j, pj in zip(new, p[k:]) if pj < ALPHA]
    result.details["rejected"] = sorted(result.details["rejected"] + [
        {"omega": second.omega[j], "zeta": second.damping[j],
         "reason": f"short-lag pass: no spectral peak of its own in the summed spectrum or in one channel's "
                   f"(peak test p-value {pj:.2g}, needs under {ALPHA:g})"}
        for j, pj in zip(new, p[k:]) if pj >= ALPHA], key=lambda r: r["omega"])
    return kept
