"""Natural frequencies from the peaks of the averaged response spectrum.

A structbench identifier plugin (entry point group
``structbench.identifiers``, name ``peaks``). For every trace of a run the
response channels of one quantity are Hann-windowed and zero-padded; their
power spectra are summed over channels and traces; the ``modes`` most
prominent peaks, in ascending frequency, are refined by a parabola through
the log power at the peak bin and its neighbours. Needs free or broadband
response; no model.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy.signal import find_peaks
from structbench import UserError

def _power(data: np.ndarray, n_fft: int) -> np.ndarray:
    """Power spectrum (n_fft // 2 + 1,) of the Hann-windowed, de-meaned ``data`` (n,)."""
    window = np.hanning(data.shape[0])
    return np.abs(np.fft.rfft((data - data.mean()) * window, n_fft)) ** 2


def identify(traces: list[Any], model: Any = None, *, modes: int = 3, quantity: str = "acceleration",
             pad: int = 8) -> dict[str, Any]:
    """One run (docs/results-format.md): ``omega`` (rad/s) of the ``modes``
    most prominent spectral peaks of the ``quantity`` channels."""
    dt = traces[0].dt
    n_fft = pad * int(2 ** np.ceil(np.log2(max(t.time.size for t in traces))))
    power = np.zeros(n_fft // 2 + 1)
    for trace in traces:
        for channel in trace.select(quantity):
            power += _power(channel.data, n_fft)
    if not power.any():
        raise UserError(f"no {quantity} channel in the traces", field="quantity")
    peaks, props = find_peaks(power, prominence=0.0)
    keep = peaks > 2 * pad                      # not in the window's main lobe at 0 Hz
    peaks, prominence = peaks[keep], props["prominences"][keep]
    chosen = np.sort(peaks[np.argsort(prominence)[::-1][:modes]])
    chosen = chosen[chosen < power.size - 1]
    log = np.log(power + power.max() * 1e-300)
    a, b, c = log[chosen - 1], log[chosen], log[chosen + 1]
    shift = 0.5 * (a - c) / (a - 2 * b + c)
    omega = 2 * np.pi * (chosen + shift) / (n_fft * dt)
    return {"method": "peaks", "structure": traces[0].structure, "repetition": traces[0].repetition,
            "tests": [t.test for t in traces], "status": "ok", "omega": omega.tolist(),
            "details": {"resolution": 2 * np.pi / (n_fft * dt), "channels": quantity, "n_fft": n_fft}}


# What structbench reads off the plugin callable (docs/plugins.md).
identify.defaults = {"modes": 3, "quantity": "acceleration", "pad": 8}
identify.help = "natural frequencies by peak picking on the averaged response spectrum (plugin structbench-peaks)"
identify.model = "none"
identify.channels = "one or more channels of the chosen quantity; a free or random response"
