"""benchmarks/modal_fuzz_ceiling.py: the oracle's statistics against
independent references (exact gamma tails, Monte Carlo, closed-form free
decays, an explicit covariance inverse, simulated periodograms)."""
import numpy as np
import pytest
import scipy.linalg as la
from modal_fuzz import unseen_record
from modal_fuzz_ceiling import decay_energy, detect, gains, quantile, random_detect, tail, transfer
from modal_synth import _mode_filter
from scipy import stats


@pytest.mark.parametrize("k", [1, 5, 30])
@pytest.mark.parametrize("p", [1e-8, 0.5])
def test_tail_of_equal_weights_is_the_gamma_tail(k, p):
    """k equal weights w: the sum of k Exp(1) times w is Gamma(k, w)."""
    w = np.full(k, 0.7)
    x = stats.gamma.isf(p, k, scale=0.7)
    assert tail(w, x) == pytest.approx(p, rel=0.04)
    if p < 0.4:
        assert quantile(w, p) == pytest.approx(x, rel=0.01)


def test_tail_of_mixed_weights_against_monte_carlo():
    w = np.array([3.0, 1.0, 0.5, 0.2, 0.2, 0.05])
    T = (np.random.default_rng(5).exponential(size=(400_000, w.size)) * w).sum(axis=1)
    x = np.quantile(T, 0.99)
    assert tail(w, x) == pytest.approx(0.01, rel=0.05)  # Monte Carlo: 1.6 % standard error
    assert tail(w, np.quantile(T, 0.5)) == pytest.approx(0.5, rel=0.02)


def test_decay_energy_is_the_closed_form_free_decay_energy_in_a_two_dim_span():
    """Seed 69: one mode, six sensors of all three quantities. The sampled
    continuous free decay from the record's initial state gives E; q, v and a
    lie in one complex amplitude times a fixed template."""
    rec = unseen_record(69)
    w, z, dt = rec["omega"][0], rec["zeta"][0], rec["dt"]
    q0, v0 = rec["parts"]["displacement"][0, 0], rec["parts"]["velocity"][0, 0]
    t = np.arange(rec["y"].shape[1]) * dt
    sigma, wd = z * w, w * np.sqrt(1 - z**2)
    q = np.exp(-sigma * t) * (q0 * np.cos(wd * t) + (v0 + sigma * q0) / wd * np.sin(wd * t))
    lam = -sigma + 1j * wd
    c = (v0 - np.conj(lam) * q0) / (lam - np.conj(lam))  # q = 2 Re(c e^{lam t})
    v = 2 * np.real(c * lam * np.exp(lam * t))
    a = -2 * z * w * v - w**2 * q
    full = {"displacement": q, "velocity": v, "acceleration": a}
    s = np.stack([rec["shapes"][i, 0] * full[qu] / rec["noise"][i] for i, qu in enumerate(rec["quantities"])])
    assert set(rec["quantities"]) == set(full)
    assert decay_energy(rec)[0] == pytest.approx(np.sum(s**2), rel=1e-8)
    kappa = {"displacement": 1.0, "velocity": lam, "acceleration": -2 * z * w * lam - w**2}
    template = np.stack([rec["shapes"][i, 0] * kappa[qu] * np.exp(lam * t) / rec["noise"][i]
                         for i, qu in enumerate(rec["quantities"])]).ravel()
    basis = np.stack([template.real, -template.imag], axis=1)  # Re(c template), c = x + j y
    coef, *_ = np.linalg.lstsq(basis, s.ravel(), rcond=None)
    assert np.linalg.norm(basis @ coef - s.ravel()) < 1e-8 * np.linalg.norm(s)
    E = np.sum(s**2)
    alpha = 1e-3 / (rec["y"].shape[1] / 2)
    assert detect(rec, 1e-3, False)[0] == pytest.approx(stats.ncx2.sf(-2 * np.log(alpha), 2, E), rel=1e-9)


def test_gains_against_an_explicit_inverse_of_the_line_covariances():
    """Seed 63: a random response, four modes, three sensors: ``size_r^2
    g^H R0^-1 g`` by numpy's inverse of the (3, 3) R0 at every 37th line."""
    rec = unseen_record(63)
    a = gains(rec)
    n = rec["y"].shape[1]
    theta = 2 * np.pi * np.arange(1, (n + 1) // 2) / n
    g = np.stack([np.stack([rec["shapes"][i, r] * transfer(w, z, rec["dt"], theta)[qu]
                            for i, qu in enumerate(rec["quantities"])], axis=1)
                  for r, (w, z) in enumerate(zip(rec["omega"], rec["zeta"]))])  # (p, K, m)
    for k in range(0, theta.size, 37):
        for r in range(rec["omega"].size):
            R0 = np.diag(rec["noise"] ** 2) + sum(rec["sizes"][o] ** 2 * np.outer(g[o, k], g[o, k].conj())
                                                  for o in range(rec["omega"].size) if o != r)
            ref = rec["sizes"][r] ** 2 * np.real(g[r, k].conj() @ np.linalg.solve(R0, g[r, k]))
            assert a[r, k] == pytest.approx(ref, rel=1e-6, abs=1e-12 * a[r].max())


@pytest.mark.parametrize("quantity", ["displacement", "velocity", "acceleration"])
def test_transfer_against_the_periodogram_of_a_simulated_state_recursion(quantity):
    """One mode (half-power band 20 lines wide, so that leakage stays small)
    driven by white force of standard deviation 3, the ZOH state recursion
    ``x_{t+1} = Ad x_t + Bd f_t`` run 300 times: the mean periodogram is ``9
    |H|^2`` (scatter 1/sqrt(300) per line, averaged over the lines)."""
    w, z, dt, n, lead, runs = 2.0, 0.05, 0.3, 2048, 400, 300
    Ad, Bd = _mode_filter(w, z, dt)
    f = 3.0 * np.random.default_rng(3).standard_normal((lead + n, runs))
    x, out = np.zeros((2, runs)), np.empty((n, runs))
    for t in range(lead + n):
        if t >= lead:
            qv = {"displacement": x[0], "velocity": x[1]}
            out[t - lead] = qv.get(quantity, f[t] - 2 * z * w * x[1] - w**2 * x[0])
        x = Ad @ x + np.outer(Bd, f[t])
    power = np.mean(np.abs(np.fft.fft(out, axis=0)) ** 2, axis=1) / n
    theta = 2 * np.pi * np.arange(1, n // 2) / n
    H = transfer(w, z, dt, theta)[quantity]
    ratio = power[1:n // 2] / (9.0 * np.abs(H) ** 2)
    for share in (0.5, 0.01):  # the half-power band, the band down to 1 % (leakage dominates further out)
        band = np.abs(H) ** 2 >= share * np.max(np.abs(H) ** 2)
        assert np.mean(ratio[band]) == pytest.approx(1.0, abs=0.03)


def test_random_detection_lies_in_0_1_and_rises_with_the_force():
    """Seed 63's faintest mode with its force scaled: P_detect from alpha
    (no force) to 1, rising; at alpha with the force gone."""
    rec = unseen_record(63)
    r = int(np.argmin(rec["snr"]))
    found = []
    for scale in (1e-6, 0.003, 0.01, 0.03, 0.1, 1.0):
        sizes = rec["sizes"].copy()
        sizes[r] *= scale
        found.append(detect(rec | {"sizes": sizes}, 1e-2, True)[r])
    found = np.array(found)
    assert found[0] == pytest.approx(1e-2, rel=0.05)
    assert np.all(np.diff(found) > 0) and np.all((found > 0) & (found <= 1))
    assert np.any((found > 0.05) & (found < 0.95))
    assert random_detect(np.full(50, 1e-12), 1e-3) == pytest.approx(1e-3, rel=0.05)


def test_random_detect_against_monte_carlo_of_the_likelihood_ratio():
    """Whitened lines ``y_k ~ CN(0, 1)`` (H0) or ``CN(0, 1 + a_k)`` (H1), the log
    likelihood ratio ``sum_k |y_k|^2 a_k / (1 + a_k) - ln(1 + a_k)`` thresholded
    at its simulated H0 99 % quantile: its simulated power."""
    a = np.array([2.0, 1.0, 0.5, 0.3, 0.1, 0.1])
    rng = np.random.default_rng(7)
    e = rng.exponential(size=(2, 400_000, a.size))  # |CN(0, 1)|^2
    llr = [np.sum(e[0] * a / (1 + a), axis=1), np.sum(e[1] * (1 + a) * a / (1 + a), axis=1)]
    power = np.mean(llr[1] > np.quantile(llr[0], 0.99))
    assert random_detect(a, 1e-2) == pytest.approx(power, rel=0.03)



def test_random_detect_against_the_exact_time_domain_test():
    """Seed 1,000,010 (a tuning seed), mode 6 (156 samples, 2 sensors):
    the Neyman-Pearson test on the exact stationary covariances ``S0``,
    ``S1`` (m n, m n) (Toeplitz blocks from the inverse FFT of ``H_i
    conj(H_j)``), whose statistic is ``sum_j (1 - 1/lambda_j) z_j^2`` under
    H0 and ``sum_j (lambda_j - 1) z_j^2`` under H1 (``lambda``: the
    generalized eigenvalues of (S1, S0)), simulated: the Whittle lines'
    P_detect at 1e-2 (frequency known) within 0.015 of it."""
    rec = unseen_record(1_000_010)
    m, n = rec["y"].shape
    L = 2**16
    S = np.zeros((rec["omega"].size, m * n, m * n))
    for r, (w, z) in enumerate(zip(rec["omega"], rec["zeta"])):
        H = transfer(w, z, rec["dt"], 2 * np.pi * np.arange(L) / L)
        for i, qi in enumerate(rec["quantities"]):
            for j, qj in enumerate(rec["quantities"]):
                c = np.fft.ifft(H[qi] * H[qj].conj()).real * (rec["sizes"][r] ** 2 * rec["shapes"][i, r]
                                                             * rec["shapes"][j, r])
                S[r, i * n:(i + 1) * n, j * n:(j + 1) * n] = la.toeplitz(c[:n], np.r_[c[0], c[L - 1:L - n:-1]])
    S0 = np.diag(np.repeat(rec["noise"] ** 2, n)) + S.sum(axis=0) - S[6]
    lam = la.eigh(S0 + S[6], S0, eigvals_only=True)
    rng = np.random.default_rng(1)
    T0 = rng.standard_normal((40_000, lam.size)) ** 2 @ (1 - 1 / lam)
    T1 = rng.standard_normal((40_000, lam.size)) ** 2 @ (lam - 1)
    exact = np.mean(T1 > np.quantile(T0, 0.99))
    assert 0.03 < exact < 0.3  # a mode between missed and found
    assert detect(rec, 1e-2, True)[6] == pytest.approx(exact, abs=0.015)
