"""An oracle's ceiling on the held-out profile's found rate (issue 21, item
3): the share of the supported modes of ``modal_fuzz.py --kind unseen``
(at least 20 periods and 5 decay times in the record, cell SNR >= 1) that
a detector could find while inventing at most ``alpha_record`` modes per
record on average.

The oracle tests one mode r of a record at a time and knows everything but
whether r is there: every other mode's signal (free decay) or spectrum
(random response), mode r's pole, shape ``shapes[:, r]`` and, for a random
response, its force's size, and the noise standard deviations ``noise``
(m,). Its false-alarm probability per test is ``alpha = alpha_record / N``:
``N = n / 2`` frequency lines searched (Bonferroni; the damping and shape
searches are free) or ``N = 1`` (frequency known).

Free decay (exact): sensor i reads ``s_i(t) = shapes[i, r] Re(c kappa_i
mu^t)`` with ``mu = exp(lambda_r dt)``, ``kappa_i`` fixed by the quantity
and ``c`` one unknown complex amplitude (q, v and a of a zero-order-hold
free decay are each a combination of ``mu^t`` and ``conj(mu)^t``), so the
signal lies in a known 2-dim span of the whitened data ``y_i(t) / noise_i``
(the other modes subtracted). The GLRT statistic, the whitened data's
energy in that span, is chi2 with 2 dof under H0 and noncentral chi2
under H1 with ``E = sum_i sum_t s_i(t)^2 / noise_i^2``:
``thr = -2 ln alpha``, ``P_detect = ncx2.sf(thr, 2, E)``.

Random response (Whittle approximation: DFT lines ``k = 1 .. n/2 - 1``
independent, ``y_k ~ CN(0, R_k)``; asymptotic in the record length, checked
against the exact time-domain test on exact stationary covariances in
tests/test_modal_fuzz_ceiling.py and docs/modal-method.md, Ceiling; it
describes the information in the record, not the rectangular-window DFT,
whose leakage from strong modes a real test would have to taper): ``R_k = sum_r size_r^2 g_rk g_rk^H + diag(noise^2)``, ``g_rk,i =
shapes[i, r] H_{quantity_i, r}(exp(j theta_k))``, the discrete transfer
functions of unseen_record's filters from the white force (variance
``size_r^2``) to q and v, and ``H_a = 1 - 2 zeta omega H_v - omega^2 H_q``.
With ``R0_k`` = ``R_k`` without mode r and ``a_k = size_r^2 g^H R0_k^-1 g``
(computed as ``|(I - U U^H) g~|^2 + sum_j |u_j^H g~|^2 / (1 + s_j^2)`` from
the SVD ``U S W^H`` of the other modes' whitened gains, free of
cancellation), the Neyman-Pearson statistic is ``T = sum_k w_k |u_k|^2``,
``u_k ~ CN(0, 1)`` under H0: ``T ~ sum_k w_k Exp(1)`` with ``w_k = a_k / (1
+ a_k)`` under H0 and ``T ~ sum_k a_k Exp(1)`` under H1. Their tails come
from the Lugannani-Rice saddle point of ``K(t) = -sum_k ln(1 - w_k t)``
(:func:`tail`; a few % off in the far tail; lines with ``a_k`` under 1e-9 of
its largest dropped), ``thr`` is the H0 tail's ``1 - alpha`` quantile.

Why an upper bound: a detector that invents at most ``alpha`` modes per
record at mode r's place reports a mode there under H0 with probability at
most ``alpha``; the oracle's test is the most powerful one at that level
(Neyman-Pearson; for the decay, the most powerful test invariant to the
unknown phase), given more than any detector knows. Not strictly: the
budget is spread evenly (a detector could spend more of it on some records
than others), the Bonferroni charge for the frequency search is a model of
the search's cost, and the Whittle and saddle-point approximations are
approximations; hence the four settings ``alpha_record`` 1e-3 and 1e-2 by
``N = n/2`` and ``N = 1``, which bracket how much the conclusion rests on
them. Per record it prints the sum of ``P_detect`` over the supported modes
in each setting and the lowest one in the first; then the ceiling (sum of
P_detect / supported modes) overall and by kind and sensor count, and how
many supported modes have P_detect under 0.5:

    python benchmarks/modal_fuzz_ceiling.py [--first 1000000] [--seeds 2000]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import optimize, stats

sys.path.insert(0, str(Path(__file__).parent))
from modal_fuzz import supported, unseen_record  # noqa: E402
from modal_synth import mode_transfer  # noqa: E402

SETTINGS = ((1e-3, False), (1e-2, False), (1e-3, True), (1e-2, True))  # (alpha_record, frequency known)
GROUPS = (("1", 1, 1), ("2-5", 2, 5), ("6+", 6, 10**9))  # sensor-count classes (name, lowest, highest)


def _saddle(v: np.ndarray, s: float, y: float) -> float:
    """Lugannani-Rice ``P(sum_k v_k Exp(1) > y)`` at the saddle point ``s``
    (``K'(s) = y``, ``s < 1 / max v``); at the mean (``|w| < 1e-4``) its
    limit ``1/2 - kappa_3 / (6 sqrt(2 pi) kappa_2^1.5)``."""
    K = -np.sum(np.log1p(-v * s))
    w = np.sign(s) * np.sqrt(max(2.0 * (s * y - K), 0.0))
    if abs(w) < 1e-4:
        return 0.5 - 2.0 * np.sum(v**3) / (6.0 * np.sqrt(2 * np.pi) * np.sum(v**2) ** 1.5)
    u = s * np.sqrt(np.sum((v / (1.0 - v * s)) ** 2))
    return float(stats.norm.sf(w) + stats.norm.pdf(w) * (1.0 / u - 1.0 / w))


def _root(v: np.ndarray, y: float) -> float:
    """The saddle point ``s``: ``K'(s) = sum v / (1 - v s) = y``, for ``max v = 1``, ``y > 0``."""
    mean = np.sum(v)
    if np.isclose(y, mean, rtol=1e-12, atol=0.0):
        return 0.0
    lo, hi = (0.0, 1.0 - 1.0 / (y + 1.0)) if y > mean else (-2.0 * v.size / y, 0.0)
    return optimize.brentq(lambda s: np.sum(v / (1.0 - v * s)) - y, lo, hi, xtol=1e-300, rtol=1e-14)


def tail(weights: np.ndarray, x: float) -> float:
    """``P(sum_k weights_k E_k > x)``, ``E_k`` iid Exp(1), ``weights`` (K,) > 0:
    the Lugannani-Rice saddle-point approximation (a few % off)."""
    c = float(np.max(weights))
    v = weights / c
    return _saddle(v, _root(v, x / c), x / c)


def quantile(weights: np.ndarray, alpha: float) -> float:
    """The ``x`` with ``tail(weights, x) = alpha`` (``alpha <= 0.3``; above it no
    bracket: ValueError), solved in
    the saddle point ``s`` (``x = K'(s)``) so that each step is closed-form."""
    c = float(np.max(weights))
    v = weights / c
    f = (lambda s: np.log(max(_saddle(v, s, np.sum(v / (1.0 - v * s))), 1e-300)) - np.log(alpha))
    s = optimize.brentq(f, 0.1 / np.sqrt(np.sum(v**2)), 1.0 - 1e-12, xtol=1e-15, rtol=1e-13)
    return c * float(np.sum(v / (1.0 - v * s)))


def decay_energy(rec: dict) -> np.ndarray:
    """The noncentrality ``E_r = sum_i sum_t s_i(t)^2 / noise_i^2`` (p,) of
    each mode of a free decay, from ``rec`` (:func:`modal_fuzz.unseen_record`)."""
    power = np.stack([np.sum(rec["parts"][qu] ** 2, axis=1) for qu in rec["quantities"]])  # (m, p)
    return np.sum(rec["shapes"] ** 2 * power / rec["noise"][:, None] ** 2, axis=0)


def transfer(omega: float, zeta: float, dt: float, theta: np.ndarray) -> dict[str, np.ndarray]:
    """``H_q``, ``H_v``, ``H_a`` (K,) of one mode from its white force at
    ``exp(j theta)`` (theta (K,) rad/sample), unseen_record's filters."""
    num_q, num_v, den = (np.polyval(c[::-1], np.exp(-1j * theta)) for c in mode_transfer(omega, zeta, dt))
    hq, hv = num_q / den, num_v / den
    return {"displacement": hq, "velocity": hv, "acceleration": 1.0 - 2 * zeta * omega * hv - omega**2 * hq}


def gains(rec: dict) -> np.ndarray:
    """``a_rk = size_r^2 g_rk^H R0_rk^-1 g_rk`` (p, K) of a random response
    at the lines ``theta_k = 2 pi k / n``, k = 1 .. n/2 - 1 (see the module
    docstring), with ``R0`` the noise and the other modes."""
    n = rec["y"].shape[1]
    theta = 2 * np.pi * np.arange(1, (n + 1) // 2) / n
    omega, zeta, shapes = rec["omega"], rec["zeta"], rec["shapes"]
    G = np.empty((theta.size, shapes.shape[0], omega.size), complex)  # whitened g~ (K, m, p)
    for r in range(omega.size):
        H = transfer(omega[r], zeta[r], rec["dt"], theta)
        G[:, :, r] = np.stack([H[qu] for qu in rec["quantities"]], axis=1) * (
            shapes[:, r] * rec["sizes"][r] / rec["noise"])[None, :]
    a = np.empty((omega.size, theta.size))
    for r in range(omega.size):
        g = G[:, :, r]
        if omega.size == 1:
            a[r] = np.sum(np.abs(g) ** 2, axis=1)
            continue
        U, sv, _ = np.linalg.svd(np.delete(G, r, axis=2), full_matrices=False)
        c = np.einsum("kij,ki->kj", U.conj(), g)
        rest = g - np.einsum("kij,kj->ki", U, c)
        a[r] = np.sum(np.abs(rest) ** 2, axis=1) + np.sum(np.abs(c) ** 2 / (1.0 + sv**2), axis=1)
    return a


def random_detect(a: np.ndarray, alpha: float) -> float:
    """P_detect of the Neyman-Pearson test at level ``alpha`` with gains ``a`` (K,) >= 0."""
    a = a[a > 1e-9 * a.max()]
    return tail(a, quantile(a / (1.0 + a), alpha))


def detect(rec: dict, alpha_record: float, known: bool) -> np.ndarray:
    """P_detect (p,) of each mode of ``rec`` by the oracle at ``alpha_record
    / N`` false alarms per test (``N = 1`` if ``known`` else ``n / 2``)."""
    alpha = alpha_record / (1.0 if known else rec["y"].shape[1] / 2.0)
    if rec["kind"] == "decay":
        return stats.ncx2.sf(-2.0 * np.log(alpha), 2, decay_energy(rec))
    return np.array([random_detect(row, alpha) for row in gains(rec)])


def ceiling(seed: int) -> dict:
    """One held-out record's supported modes and their P_detect (one array per setting)."""
    rec = unseen_record(seed)
    held = supported(rec)
    detected = [detect(rec, alpha_record, known)[held] if held.any() else np.zeros(0)
                for alpha_record, known in SETTINGS]
    return {"seed": seed, "kind": rec["kind"], "sensors": rec["y"].shape[0], "supported": int(held.sum()),
            "p": detected}


def summary(rows: list[dict]) -> str:
    """The ceilings over ``rows`` of :func:`ceiling`: overall, by kind and
    sensor class, per setting, with the count of supported modes at P_detect < 0.5."""
    lines = []
    for i, (alpha_record, known) in enumerate(SETTINGS):
        name = f"alpha_record {alpha_record:g}, N = {'1' if known else 'n/2'}"
        parts = [("all", rows)] + [(f"{kind} {g}", [r for r in rows if r["kind"] == kind and lo <= r["sensors"] <= hi])
                                   for kind in ("decay", "random") for g, lo, hi in GROUPS]
        cells = []
        for label, chosen in parts:
            p = np.concatenate([r["p"][i] for r in chosen]) if chosen else np.zeros(0)
            share = f"{100 * p.sum() / p.size:.1f} %" if p.size else "-"
            cells.append(f"{label} {share} of {p.size} ({int(np.sum(p < 0.5))} under 0.5)")
        lines.append(f"{name}: " + "; ".join(cells))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--first", type=int, default=1_000_000)
    args = parser.parse_args(argv)
    rows = []
    for seed in range(args.first, args.first + args.seeds):
        row = ceiling(seed)
        rows.append(row)
        sums = "/".join(f"{p.sum():.3f}" for p in row["p"])
        low = f"{row['p'][0].min():.3g}" if row["supported"] else "-"
        print(f"seed {seed} kind {row['kind']} sensors {row['sensors']} supported {row['supported']} "
              f"p_detect sum {sums} lowest {low}", flush=True)
    print(f"\nceiling, seeds {args.first}-{args.first + args.seeds - 1} (sum of P_detect / supported modes):\n"
          f"{summary(rows)}")


if __name__ == "__main__":
    main()
