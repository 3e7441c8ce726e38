"""A weak harmonic of another shape than the random response near it, judged
in every sensor's lines (issue 25.5, sixth round): the coherent share takes
its sinusoid at the band's strongest whitened line, and a broad pole beside
such a line whose band keeps no peak once the sinusoid is out is the line's
(identifier/modal/harmonics_poles.py, harmonics.py)."""
from __future__ import annotations

import numpy as np

from modal_harmonics import velocity
from structbench.identifier.modal.harmonics import Screened, confirm
from structbench.identifier.modal.harmonics_lines import _spectrum, background
from structbench.identifier.modal.harmonics_poles import coherent_share, share_bound


def _record(seed: int, ratio: float, line: float, m: int, n: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """One input's white response on ``m`` channels (shape ``phi``, 2 % noise) plus a sinusoid of a
    random other shape at ``line`` (in lines) whose Hann line stands ``ratio`` times the summed
    periodogram's median there; returns the record (m, n) and ``phi``."""
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.5, 1.5, m) * rng.choice([-1.0, 1.0], m)
    y = np.outer(phi, rng.standard_normal(n)) + 0.02 * np.abs(phi)[:, None] * rng.standard_normal((m, n))
    P = np.sum(np.abs(_spectrum(y))**2, axis=0)
    j = int(line)
    psi = rng.standard_normal(m)
    alpha = np.sqrt(ratio * np.median(P[j - 100:j + 100]) * 16 / n**2 / np.sum((psi / y.std(axis=1))**2))
    bin_w = 2 * np.pi / (n * dt)
    return y + alpha * np.outer(psi, np.cos(line * bin_w * np.arange(n) * dt + 0.7)), phi


def test_the_coherent_share_takes_the_sinusoid_at_the_strongest_whitened_line():
    """A sinusoid 3 times the summed periodogram's median (weak there: one
    of the band's 7 random lines is as strong in most records) 2.6 lines
    from a narrow pole (half-width 1 line, 6.3 decay times), of another
    shape than the one-input response on 8 channels, 10 seeds: taken at the
    strongest summed line (the code before) one sinusoid held almost none of
    the band in 4 records (-0.007 to 0.096); at the strongest whitened line
    it holds over 0.8 in every record and over ``share_bound`` (0.94) in 8
    (0.84 and 0.91 in the other two: a weak line's share scatters)."""
    n, dt = 65_536, 0.1
    bin_w = 2 * np.pi / (n * dt)
    shares = []
    for seed in range(10):
        y, _ = _record(seed, 3.0, 3002.6, 8, n, dt)
        P = np.sum(np.abs(_spectrum(y))**2, axis=0)
        w = 3000 * bin_w
        shares.append(coherent_share(y, dt, P, background(P), w, bin_w / w)[0])
    assert min(shares) > 0.8 and sum(s > share_bound(2 * np.pi) for s in shares) >= 8, np.round(shares, 3)


def test_a_broad_pole_beside_a_line_whose_band_keeps_no_peak_is_the_lines():
    """Benchmark frame seed 7504 (a fresh seed of the fifth round, a tuning
    seed since): a 0.11x harmonic at 50 Hz got an SSI pole of 0.05 %
    damping (half-width 7.5 lines) 13.7 lines beside it; the pole's band did
    not rise over its surroundings, but its line stood outside the line
    test's reach, so it was reported as a mode. Here: a line 60 times the
    median on 6 channels, such a pole 13.7 lines beside it: a harmonic
    (``coherent``) at the line, the pole dropped. With a mode of that
    half-width under the pole (peak 10 times the background) the band keeps
    its peak once the sinusoid is out: the pole stays a mode."""
    n, dt = 150_001, 1 / 500
    bin_w = 2 * np.pi / (n * dt)
    line = 15_000.4
    pole = (line - 13.7) * bin_w
    zeta = np.array([7.5 * bin_w / pole])
    y, phi = _record(3, 60.0, line, 6, n, dt)
    drop, found = confirm(Screened([y], [], []), dt, np.array([pole]), zeta, zeta, np.array([0.5 * bin_w]))
    assert drop.tolist() == [True] and [f.test for f in found] == ["coherent"]
    assert abs(found[0].omega / bin_w - line) < 1
    rng = np.random.default_rng(4)
    q = velocity(np.array([pole]), zeta, phi[:, None], rng.standard_normal((1, n)), dt)
    y += q / q.std() * np.std(y[:, :1000]) * np.sqrt(10 * 7.5 * np.pi / (n / 2))
    drop, found = confirm(Screened([y], [], []), dt, np.array([pole]), zeta, zeta, np.array([0.5 * bin_w]))
    assert drop.tolist() == [False] and found == []
