"""Issue 21, eleventh round: a stationary record's modes are found by poles
stable within 2 % and 0.3 (identifier/modal/stabilisation.py), and a mode
of temporal coherence under 0.8 needs a spectral peak of its own
(identifier/modal/support.py). Records of benchmarks/modal_fuzz.py's
held-out profile at tuning seeds (800,000-800,999, looked at for this
round)."""
from __future__ import annotations

import modal_fuzz
import numpy as np

from structbench.identifier import modal
from structbench.identifier.modal.stabilisation import Criteria


def _identify(seed: int) -> tuple[dict, modal.Identification]:
    rec = modal_fuzz.unseen_record(seed)
    return rec, modal.identify([modal_fuzz.unseen_trace(rec)])


def test_a_heavily_damped_mode_of_a_short_record_is_found(monkeypatch):
    """Seed 800140: one acceleration sensor, 849 samples, one mode (4.04
    rad/s, zeta 0.097, 122 decay times). Its poles move by over 1 % and
    10 % in damping between orders: at the free-decay tolerances it is
    stable at too few orders and nothing is reported; now it is, within
    its stated 95 % interval."""
    rec, result = _identify(800140)
    (w,), (se,) = result.omega, result.omega_std
    assert abs(w - rec["omega"][0]) < 1.96 * se < 0.1 * w
    assert abs(result.damping[0] - rec["zeta"][0]) < 1.96 * result.damping_std[0]
    monkeypatch.setattr(Criteria, "for_record", lambda stationary, fraction: Criteria(min_fraction=fraction))
    assert modal.identify([modal_fuzz.unseen_trace(rec)]).omega == []


def test_a_loosely_coherent_cluster_without_a_peak_is_listed_apart(monkeypatch):
    """Seed 800224 (43 sensors, modes 2.04-30.3 rad/s): the looser
    tolerances cluster covariance-noise poles at 50.6 rad/s, above every
    mode, coherence 0.65, no peak; listed apart for that. Without the rule
    (``COHERENT`` 0) it is reported."""
    rec, result = _identify(800224)
    assert np.all(np.min(np.abs(np.array(result.omega)[:, None] / rec["omega"] - 1), axis=1) < 0.05)
    noise = [r for r in result.details["rejected"]
             if abs(r["omega"] - 50.6) < 0.5 and not r["reason"].startswith("deflated pass")]  # the first pass's
    assert len(noise) == 1 and "under 0.8" in noise[0]["reason"] and "no spectral peak" in noise[0]["reason"]
    monkeypatch.setattr(modal.support, "COHERENT", 0.0)
    loose = modal.identify([modal_fuzz.unseen_trace(rec)])
    assert np.any(np.abs(np.array(loose.omega) - 50.6) < 0.5)


def test_of_two_unresolved_modes_the_less_coherent_is_dropped(monkeypatch):
    """Seed 800457 (10 sensors; a heavily damped mode at 61.15 rad/s,
    zeta 0.09): SSI's estimate at 60.69 (coherence 0.76, with a peak) and a
    noise cluster at 60.73 (coherence 0.13, stable at most orders; shapes
    unlike, so not a duplicate by MAC) share the mode's peak. The cluster
    lies above every coherent candidate, so stabilisation's ``STEADY`` rule
    does not exempt it (eighteenth round) and the coherence test lists it.
    With ``COHERENCE`` at 0.1 it passes that test and the duplicate rule
    lists it as the less coherent; without that rule as well the better
    supported noise cluster is kept instead (the support-ordered duplicate
    rule)."""
    def near(result: modal.Identification) -> list[float]:
        return [c for w, c in zip(result.omega, result.details["coherence"]) if abs(w / 61.151 - 1) < 0.05]

    def listed(result: modal.Identification, reason: str) -> list[dict]:
        return [r for r in result.details["rejected"] if r["reason"].startswith(reason)
                and "coherence 0.13" in r["reason"] and abs(r["omega"] / 61.151 - 1) < 0.05]

    rec, result = _identify(800457)
    assert len(near(result)) == 1 and near(result)[0] > 0.6
    assert len(listed(result, "temporal coherence")) == 1
    monkeypatch.setattr(modal, "COHERENCE", 0.1)
    loose = modal.identify([modal_fuzz.unseen_trace(rec)])
    assert len(near(loose)) == 1 and near(loose)[0] > 0.6
    assert len(listed(loose, "duplicate")) == 1
    monkeypatch.setattr(modal.support, "_less_coherent", lambda *args: None)
    assert max(near(modal.identify([modal_fuzz.unseen_trace(rec)]))) < 0.6
