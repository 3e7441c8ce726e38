"""Whether the record supports a mode the SSI-cov stabilisation found, and
standard errors that include the bias of a short record.

A mode seen in the stabilisation diagram is reported only when the record
itself can carry it; otherwise it is listed apart (``rejected``), with its
reason. The tests, for a mode of natural frequency ``omega`` rad/s and
damping ratio ``zeta`` in records of total length ``T`` s (several traces of
a run add up as independent records):

- periods: ``omega T / (2 pi) >= MIN_PERIODS`` in a stationary record. A
  pole fitted to fewer periods of a random response is not told apart from
  the slow trend of the excitation or the start-up transient. A free
  response is deterministic: its poles show in a fraction of a period
  above the noise, and the jackknife measures how well; it needs
  ``FREE_PERIODS``;
- decay times (stationary records only): ``zeta omega T >= MIN_DECAYS``
  (with ``zeta`` at least ``ZETA_FLOOR``). A random response that holds
  under a couple of correlation times of a mode has not forgotten its
  initial state: its covariances are not those of a stationary response,
  and the damping ratio is not determined;
- repetition: found again by every jackknife replicate but at most one
  (:func:`identifier.modal.uncertainty.jackknife`); a mode missed by more
  is a pole of the covariance estimates' own noise;
- finite errors: ``omega_std`` and ``damping_std`` finite and positive and
  ``omega_std < MAX_RELATIVE omega`` (a pole as uncertain as that is no
  estimate);
- growing: a damping ratio below zero by more than ``UNDAMPED`` of its
  standard errors, ``zeta + UNDAMPED zeta_std < 0``, is a pole that grows:
  no mode of a passive structure (a true mode's interval holds its
  damping, which is not negative), but the second pole SSI fits beside a
  heavily damped mode (a free decay of one acceleration sensor, tuning
  seed 1,004,339: -0.016 +- 0.0024 at 36.9 rad/s beside the true 38.7,
  ``zeta`` 0.063). Assumes a passive structure;
- band edges: a mode whose half-power band reaches within 10 % of the
  edge of the band a filter or resampling left in the record (its spectrum
  falls off a cliff there), or lies past it, is not told from the filter's
  own poles (:mod:`identifier.modal.band_edges`);
- duplicates: two modes whose shapes agree (MAC above ``DUPLICATE_MAC``
  in physical units or in unit-RMS channels: a channel of a large
  quantity that holds little of the mode, e.g. another mode's
  acceleration, makes one shape's two estimates unlike in physical
  units; a noisy channel, in unit-RMS ones) and whose frequencies the
  record does not resolve,

      |omega_a - omega_b| < max(3 sqrt(se_a^2 + se_b^2), 2 pi / T,
                                (zeta_a omega_a + zeta_b omega_b) / 2),

  are one mode seen twice (a pole cluster split by the shape noise of a
  short record). So are two unresolved modes of unlike shapes when the
  shapes' standard errors (the jackknife's, per entry of the reported real
  shapes ``u_a``, ``u_b`` (m,), errors ``s_a``, ``s_b``) explain the
  difference: with the scale ``c = sum w u_a u_b / sum w u_a^2``, ``w = 1 /
  (s_b^2 + s_a^2)``,

      chi2 = sum_i (u_b,i - c u_a,i)^2 / (s_b,i^2 + c^2 s_a,i^2)  <  chi2.isf(SAME_SHAPE, m - 1):

  two estimates of one shape differ by their noise, ``chi2 ~ chi-square(m
  - 1)``, while the shapes of two modes differ by more (a weak mode's
  shape, noisy, has a low MAC to a strong mode's own even when it is that
  mode: the MAC alone let such second estimates through). Not applied
  where an error is not finite (over ``ROW_CHANNELS`` sensors, or a mode
  some replicates missed) or ``m < 2``, nor to free responses: there an
  unresolved pair of unlike shapes goes on to the close-pair fit
  (:mod:`identifier.modal.close_pairs`), which tells one mode from two by
  the record itself. So are two modes of any shapes whose frequencies and
  damping ratios agree far more closely than their errors allow for two
  estimates (``|delta omega| < TWIN sqrt(se_a^2 + se_b^2)``, likewise
  ``zeta``): one pole whose shape the record splits in two. The one of
  more stable poles is kept.

Spectral peak (stationary records), for a mode of the shape of a better
supported one (MAC above ``peak_pairs.SHADOW_MAC``, the stabilisation's
``mac_min``; the better supported one too where its damping is told from
zero), and for each of two alike modes within one's band (both, the
better supported too; shapes compared in unit-RMS channels,
:func:`identifier.modal.peak_pairs.shadows`): the record's spectrum holds a
peak at the mode, by the likelihood-ratio test of
:mod:`identifier.modal.peak_test` (p-value under ``peak_test.ALPHA`` over
the half-power bands the record holds). SSI of high order fits poles to
the estimation noise of a strong mode's covariances, which has that
mode's shape (``delta R_l = phi e_l phi^T`` for one mode): stable at half
the orders or more, coherent, found again by the jackknife (whose
replicates share the noise), but without a peak of their own. Applied to
such shadows only: the summed spectrum hides weak modes of other shapes
under their neighbours' response, which SSI resolves by their shapes.
Before it (:mod:`identifier.modal.peak_pairs`, ``SHADOW_MAC`` there): a
pair of alike shapes within a few half-power half-widths is one mode
unless the band needs two oscillator terms against one fitted freely (one
broad mode fitted by two poles, the better supported of which can be the
spurious one), and a candidate beside a better supported one of another
shape within its standard errors must show a peak in the channels
projected on its shape apart from its neighbours'. After them
(:mod:`identifier.modal.peak_split`): a candidate whose band needs two
oscillator terms of free poles against one, resolved from each other,
its own pole between them or far from both, is one pole over several
modes (its damping inflated to span them) and is rejected.

Temporal coherence (:mod:`identifier.modal`) is tested before these and its
failures are listed with them. A stationary candidate that passes it with
coherence under ``COHERENT`` (its observability vectors only loosely the
geometric sequence of its eigenvalue) must show a spectral peak of its own
like a weak candidate below (:func:`identifier.modal.peak_pairs.screen`):
a cluster of covariance-noise poles stable enough to form a mode reaches a
coherence of 0.6-0.8 but holds no peak (docs/modal-method.md, twelfth
round). Of two candidates the record does not resolve (as for duplicates
below), one under ``COHERENT``, the less coherent is dropped as a
duplicate whatever its shape: noise poles stable at most orders beside a
mode (kept by the stabilisation's ``STEADY`` rule at any coherence) share
its peak. The band fit may widen a reported mode's errors after these tests
(:mod:`identifier.modal.band_fit`); a mode kept by that exemption alone
that the widened errors leave unresolved from a more coherent reported one
is then dropped as its duplicate (:func:`less_coherent_after`): its own
band has moved it onto the other.

A mode stable at under ``MIN_STABLE`` of the model orders
(:mod:`identifier.modal.stabilisation` asks ``min_fraction`` of every
candidate) is reported only when the record pins it down,

    omega_std < max(LOOSE, BANDWIDTH zeta) omega:

the structure's poles recur at every order past its own, and a weak true
mode that does not (the spatially aliased modes of a beam on few sensors
in a long record: a third of the orders) is precise, while poles fitted
to the noise of a short or noisy record come and go and scatter. Precise
is relative to the mode's own half-power bandwidth ``2 zeta omega``: a
true mode seen over ``N = zeta omega T`` decay times of a random response
has ``omega_std / (zeta omega) ~ 1 / sqrt(N)`` (the random error) plus
``1 / N`` (the short-record bias), under ``BANDWIDTH`` from about 5 decay
times on, so a heavily damped true mode is as well pinned down within its
bandwidth as a lightly damped one though far less in absolute terms; a
noise pole scatters over more than its own bandwidth. A precise one whose
damping the record does not tell from zero (``|zeta| < UNDAMPED
zeta_std``, the 95 % interval) must show a spectral peak of its own
(stationary records; :mod:`identifier.modal.peak_pairs`, weak
candidates): SSI fits lightly damped poles to broadband noise above the
highest mode (an acceleration channel's force feed-through), precise to
under ``LOOSE`` but without a peak. So must such a candidate however
stable it is and however wide its damping interval: noise poles stable at
most orders, damping not told from zero and no peak, lie beside or
between true modes, or above them in a short record (issue 21, eighth
and thirteenth rounds, docs/modal-method.md). A heavily damped true mode
whose damping the record does not tell from zero and whose peak the
test's band (cut at ``omega / 2``) or a neighbour's term hides is listed
apart with that reason.

Short-record bias. In a stationary random response of ``T`` seconds the
covariance estimates ``R_l`` of a mode of decay rate ``sigma = zeta omega``
carry errors correlated over all lags, of relative size
``1 / (sigma T)`` (the response's memory of its start and the finite
averaging window; Bendat & Piersol's ``1 / (B_e T)`` with the half-power
bandwidth ``B_e ~ zeta omega``). The identified pole ``s = -sigma + i
omega_d`` then moves by ``|delta s| ~ sigma / (sigma T) = 1 / T`` rad/s,
whatever the mode, and the delete-one-group jackknife, whose groups share
that error, does not see it. Its standard deviation is added to the
jackknife variance:

    se_omega^2 = se_jk,omega^2 + (BIAS / T)^2 + se_order,omega^2,
    se_zeta^2  = se_jk,zeta^2  + (BIAS / (omega T))^2 + se_order,zeta^2

(``delta zeta = -delta Re s / omega`` to first order). The estimates of
one mode at the model orders it is stable at (the medians of the
stabilisation) scatter when the model orders fall short of what the record
holds (noise and other modes take up part of the subspace): that scatter,
the standard deviation over the mode's stable poles, is a bias the
jackknife's replicates share, and it is added too (``se_order``, both
kinds of record). A free decay's poles
are deterministic (no excitation, only sensor noise): there is no
``1 / T`` term. Assumes a linear
time-invariant structure under broadband excitation; fails (too wide or too
narrow intervals) when the excitation is far from white near the mode.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2 as chi_square

from structbench.models.mac import mac

from . import band_edges, peak_pairs, peak_split, peak_test
from .ssi.poles import real_shapes

MIN_PERIODS = 10.0  # least periods of a mode in a stationary record
FREE_PERIODS = 1.0  # ... in a free response
MIN_DECAYS = 2.0  # least decay times 1 / (zeta omega) of a mode in a stationary record
ZETA_FLOOR = 1e-4  # damping ratio at least this when counting decay times
MIN_STABLE = 0.5  # share of the model orders below which a mode must be precise ...
LOOSE = 0.005  # ... omega_std < LOOSE omega
BANDWIDTH = 0.5  # ... or omega_std < BANDWIDTH zeta omega (a share of its half-power bandwidth)
UNDAMPED = 1.96  # ... and a mode among them whose damping is within this many standard errors of 0 needs a peak
COHERENT = 0.8  # a stationary mode of temporal coherence under this needs a spectral peak of its own
MAX_RELATIVE = 0.05  # largest omega_std / omega of a reported mode
DUPLICATE_MAC = 0.8  # shapes this alike (MAC) and unresolved in frequency: one mode
TWIN = 0.05  # poles closer than this many standard errors in omega and zeta: one mode
SAME_SHAPE = 0.01  # ... two unresolved shapes whose difference has a chi-square above chance this often: one mode
BIAS = 1.0  # the short-record bias's standard deviation, x 1 / T rad/s


@dataclass(frozen=True)
class Verdict:
    """Per candidate mode (k,): reported or not and, when not, why (``""`` when reported)."""

    keep: np.ndarray
    reasons: list[str]


def record_bias(omega: np.ndarray, length: float, decay: bool) -> tuple[np.ndarray, np.ndarray]:
    """Standard deviations (k,) of the short-record bias of omega (rad/s) and
    zeta of modes at ``omega`` (k,) rad/s in stationary records of total
    ``length`` s: ``BIAS / T`` and ``BIAS / (omega T)``; zeros for free
    decays (see the module docstring)."""
    omega = np.asarray(omega, dtype=float)
    if decay or length <= 0:
        return np.zeros_like(omega), np.zeros_like(omega)
    return np.full_like(omega, BIAS / length), BIAS / (np.maximum(omega, 1e-300) * length)


def with_bias(omega: np.ndarray, omega_std: np.ndarray, zeta_std: np.ndarray, length: float,
              decay: bool, order_std: tuple[np.ndarray, np.ndarray] | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """``omega_std`` and ``zeta_std`` (k,) with the short-record bias
    (:func:`record_bias`) and the model-order scatter ``order_std`` (omega,
    zeta; each (k,)) added in quadrature; NaN stays NaN."""
    bo, bz = record_bias(omega, length, decay)
    so, sz = order_std if order_std is not None else (np.zeros_like(bo), np.zeros_like(bz))
    return np.sqrt(omega_std**2 + bo**2 + so**2), np.sqrt(zeta_std**2 + bz**2 + sz**2)


def judge(omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray, zeta_std: np.ndarray,
          missed: np.ndarray, support: np.ndarray, stable: np.ndarray, shapes: np.ndarray, length: float,
          decay: bool, groups: int, errors: bool = True, shape_std: np.ndarray | None = None,
          spectrum: tuple[list[np.ndarray], float] | None = None,
          coherence: np.ndarray | None = None, edges: tuple[float, float, float, float] | None = None) -> Verdict:
    """The verdict on candidate modes (k,): ``omega`` rad/s, ``zeta``, their
    standard errors (bias included), ``missed`` (jackknife replicates that did
    not find each), ``support`` (stable poles), ``stable`` (share of the
    model orders each is stable at), complex ``shapes`` (m, k),
    records of total ``length`` s, ``decay``: free responses; ``groups``:
    jackknife replicates; ``errors``: standard errors were estimated (with
    ``uncertainty="off"`` the repetition and error tests are skipped);
    ``shape_std`` (m, k): standard errors of the entries of the real
    shapes (:func:`identifier.modal.ssi.poles.real_shapes`), NaN where
    unknown; ``spectrum``: the records (m, n_i) and their ``dt`` s, for
    the spectral-peak test (stationary records only) and the duplicate
    rule's MAC in unit-RMS channels as well as physical units;
    ``coherence`` (k,): each candidate's temporal coherence (none: not
    tested against ``COHERENT``); ``edges``: the records' band
    (:func:`identifier.modal.band_edges.band`, none: not tested). Tests and
    thresholds in the module docstring."""
    k = omega.size
    reasons = [""] * k
    periods = omega * length / (2 * np.pi)
    decays = np.maximum(zeta, ZETA_FLOOR) * omega * length
    for i in range(k):
        if periods[i] < (FREE_PERIODS if decay else MIN_PERIODS):
            reasons[i] = f"{periods[i]:.3g} periods in the record (needs {FREE_PERIODS if decay else MIN_PERIODS:g})"
        elif not decay and decays[i] < MIN_DECAYS:
            reasons[i] = (f"{decays[i]:.3g} decay times 1 / (zeta omega) in the stationary record "
                          f"(needs {MIN_DECAYS:g})")
        elif errors and missed[i] > 1:
            reasons[i] = f"not found again by {int(missed[i])} of {groups} jackknife replicates"
        elif errors and not (np.isfinite(omega_std[i]) and np.isfinite(zeta_std[i])
                             and omega_std[i] > 0 and zeta_std[i] > 0):
            reasons[i] = "no finite standard error"
        elif errors and omega_std[i] > MAX_RELATIVE * omega[i]:
            reasons[i] = f"omega_std {omega_std[i] / omega[i]:.2g} x omega (over {MAX_RELATIVE:g})"
        elif errors and stable[i] < MIN_STABLE and omega_std[i] >= max(LOOSE, BANDWIDTH * abs(zeta[i])) * omega[i]:
            reasons[i] = (f"stable at {stable[i]:.0%} of the model orders (under {MIN_STABLE:.0%}) with "
                          f"omega_std {omega_std[i] / omega[i]:.2g} x omega (at least {LOOSE:g} and "
                          f"{BANDWIDTH:g} zeta)")
        elif errors and zeta[i] + UNDAMPED * zeta_std[i] < 0:
            reasons[i] = (f"damping ratio {zeta[i]:.3g} below zero by over {UNDAMPED:g} standard errors "
                          f"({zeta_std[i]:.2g}): a growing pole, no mode of a passive structure")
    if edges is not None:
        reasons = [r or edge for r, edge in zip(reasons, band_edges.at_edges(edges, omega, zeta))]
    scaled = peak_pairs.unit_scaled(spectrum[0], shapes) if spectrum is not None else shapes
    shape_mac = np.maximum(mac(shapes, shapes), mac(scaled, scaled)) if k > 1 else np.zeros((k, k))
    if spectrum is not None and not decay:
        top, why = _weak(zeta, zeta_std, coherence)
        summed = peak_test.summed_periodogram(spectrum[0])  # both screens read it
        peak_pairs.screen(spectrum[0], spectrum[1], omega, zeta, omega_std, np.asarray(support), scaled,
                          reasons, top, why, np.abs(zeta) >= UNDAMPED * zeta_std, summed)
        peak_split.screen(spectrum[0], spectrum[1], omega, zeta, omega_std, reasons, summed)
    keep = np.array([not r for r in reasons], dtype=bool)
    if k > 1:
        alike = shape_mac > DUPLICATE_MAC
        if not decay:  # a free response's unresolved pair is left to the close-pair fit (module docstring)
            alike |= same_shape(shapes, shape_std)
        se = np.where(np.isfinite(omega_std), omega_std, 0.0)
        sz = np.where(np.isfinite(zeta_std), zeta_std, 0.0)
        unresolved = unresolved_pairs(omega, zeta, omega_std, length)
        if coherence is not None and not decay:
            _less_coherent(omega, np.asarray(coherence, float), unresolved, keep, reasons)
        for i in np.argsort(-np.asarray(support), kind="stable"):  # the best supported first
            if not keep[i]:
                continue
            for j in np.flatnonzero(keep):
                if j == i or support[j] > support[i] or (support[j] == support[i] and j < i):
                    continue
                twins = (abs(omega[i] - omega[j]) < TWIN * np.hypot(se[i], se[j])
                         and abs(zeta[i] - zeta[j]) < TWIN * np.hypot(sz[i], sz[j]))
                if twins or (alike[i, j] and unresolved[i, j]):
                    keep[j] = False
                    reasons[j] = f"duplicate of the mode at {omega[i]:.6g} rad/s (not resolved by the record)"
    return Verdict(keep, reasons)


def unresolved_pairs(omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray, length: float) -> np.ndarray:
    """(k, k) bool: the pairs of modes at ``omega`` (k,) rad/s, damping
    ``zeta`` (k,), standard errors ``omega_std`` (k,) (NaN: 0) that records
    of ``length`` s do not resolve (module docstring, duplicates)."""
    se = np.where(np.isfinite(omega_std), omega_std, 0.0)
    width = np.abs(zeta) * omega
    resolve = np.maximum.reduce([3 * np.hypot(se[:, None], se[None, :]), np.full((omega.size,) * 2, 2 * np.pi / length),
                                 0.5 * width[:, None] + 0.5 * width[None, :]])
    return np.abs(omega[:, None] - omega[None, :]) < resolve


def less_coherent_after(omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray, coherence: np.ndarray,
                        length: float, below: float) -> tuple[np.ndarray, list[dict]]:
    """Reported modes (k,) at ``omega`` rad/s, damping ``zeta``, whose
    ``omega_std`` grew after :func:`judge` (the band fit's widening,
    :mod:`identifier.modal.band_fit`): a mode of temporal coherence
    (``coherence`` (k,), NaN: unknown) under ``below``, reported only for
    being stable at most model orders, that records of ``length`` s no
    longer resolve from a more coherent one at its final errors
    (:func:`unresolved_pairs`) is that mode seen again (its own band has
    moved it there) and is dropped. Returns the modes kept (k,) bool and
    the dropped ones as ``details.rejected`` entries."""
    keep, reasons = np.ones(omega.size, dtype=bool), [""] * omega.size
    _less_coherent(omega, np.asarray(coherence, float), unresolved_pairs(omega, zeta, omega_std, length), keep,
                   reasons, below, " at its errors widened by its band")
    return keep, rejected(omega, zeta, Verdict(keep, reasons))


def _weak(zeta: np.ndarray, zeta_std: np.ndarray, coherence: np.ndarray | None) -> tuple[np.ndarray, list[str]]:
    """Per candidate (k,) the upper end ``|zeta| + UNDAMPED zeta_std`` of its
    damping interval where it must show a spectral peak (module docstring:
    damping not told from zero, or temporal coherence under ``COHERENT``),
    NaN elsewhere, and why it must."""
    top = np.abs(zeta) + UNDAMPED * np.where(np.isfinite(zeta_std), zeta_std, 0.0)
    undamped = np.abs(zeta) < UNDAMPED * zeta_std
    coherence = np.ones(zeta.size) if coherence is None else np.asarray(coherence, float)
    loose = coherence < COHERENT
    why = ["damping not told from 0" if u else f"temporal coherence {c:.2f} (under {COHERENT:g})" if lo else ""
           for u, lo, c in zip(undamped, loose, coherence)]
    return np.where(undamped | loose, top, np.nan), why


def _less_coherent(omega: np.ndarray, coherence: np.ndarray, unresolved: np.ndarray, keep: np.ndarray,
                   reasons: list[str], below: float = COHERENT, at: str = "") -> None:
    """Of two kept candidates the record does not resolve (``unresolved``
    (k, k)), one of temporal coherence under ``below``, the less coherent
    is dropped (module docstring), most coherent kept first; ``at`` says
    at which errors in its reason."""
    for i in np.argsort(-coherence, kind="stable"):
        for j in np.flatnonzero(keep & unresolved[i]):
            if keep[i] and j != i and coherence[j] < min(coherence[i], below):
                keep[j] = False
                reasons[j] = (f"duplicate of the mode at {omega[i]:.6g} rad/s (not resolved by the record{at}; "
                              f"temporal coherence {coherence[j]:.2f}, under {below:g} and its {coherence[i]:.2f})")


def rejected(omega: np.ndarray, zeta: np.ndarray, verdict: Verdict) -> list[dict]:
    """The modes not reported, as the results' ``details.rejected`` entries:
    ``omega`` rad/s, ``zeta``, ``reason``."""
    return [{"omega": float(w), "zeta": float(z), "reason": r}
            for w, z, r, k in zip(omega, zeta, verdict.reasons, verdict.keep) if not k]


def same_shape(shapes: np.ndarray, shape_std: np.ndarray | None) -> np.ndarray:
    """(k, k): whether each pair of complex ``shapes`` (m, k) is one shape
    within the standard errors ``shape_std`` (m, k) of their real forms
    (the chi-square of the module docstring under ``chi2.isf(SAME_SHAPE,
    m - 1)``); False where an error is not finite or positive, or ``m < 2``."""
    m, k = shapes.shape
    out = np.zeros((k, k), dtype=bool)
    if shape_std is None or m < 2 or k < 2:
        return out
    u, s = real_shapes(shapes), np.asarray(shape_std, dtype=float)
    ok = np.all(np.isfinite(s) & (s > 0), axis=0)
    bound = chi_square.isf(SAME_SHAPE, m - 1)
    for a in np.flatnonzero(ok):
        for b in np.flatnonzero(ok):
            if b <= a:
                continue
            w = 1.0 / (s[:, a] ** 2 + s[:, b] ** 2)
            c = np.sum(w * u[:, a] * u[:, b]) / max(np.sum(w * u[:, a] ** 2), 1e-300)
            value = np.sum((u[:, b] - c * u[:, a]) ** 2 / (s[:, b] ** 2 + c**2 * s[:, a] ** 2))
            out[a, b] = out[b, a] = value < bound
    return out
