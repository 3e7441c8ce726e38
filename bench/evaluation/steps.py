"""The identifications of the reproduction (:data:`STEPS`): per campaign
the method, the tests it reads, its options, and what it is in the report."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Step:
    """One identification: campaign, results tag, method, the test groups and
    tests (patterns) it reads, ``joint`` runs, method ``options`` and how many
    ``repetitions`` (default: all); ``variant`` says what it is in the report."""

    campaign: str
    tag: str
    method: str
    variant: str
    groups: tuple[str, ...] = ()
    tests: tuple[str, ...] = ()
    joint: bool = False
    options: Mapping[str, Any] = field(default_factory=dict)
    repetitions: int | None = None  # identify only the first that many

    @property
    def stem(self) -> str:
        return f"{self.method}-{self.tag}"


LS, PT, RY, MD = "least-squares", "perturbation", "rayleigh", "modal"
STEPS: tuple[Step, ...] = (
    Step('ch3', 'm4', LS,
         'measured u, v; noise-weighted least squares (the headline ch3-m4)',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 4}),
    Step('ch3', 'm8', LS,
         'measured u, v; noise-weighted least squares (the headline ch3-m8)',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8}),
    Step('ch3', 'm4-plain', LS,
         'measured u, v; plain least squares as in the dissertation',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 4, 'weighting': 'none'}),
    Step('ch3', 'm8-plain', LS,
         'measured u, v; plain least squares as in the dissertation',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8, 'weighting': 'none'}),
    Step('ch3', 'm8-integrated', LS,
         'u, v integrated from the noisy 1 ms accelerations (hold-aware Simpson)',
         groups=('harmonic',),
         options={'estimator': 'ols', 'interval': 0.5, 'samples': 8, 'integration': 'zoh-simpson'}),
    Step('ch3', 'm8-trapezoid', LS,
         'u, v integrated from the noisy 1 ms accelerations (trapezoidal rule)',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8, 'integration': 'trapezoid'}),
    Step('ch3', 'm8-noisy-displacement', LS,
         '2 % noise on the displacement and velocity sensors too',
         groups=('noisy-displacement',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8}),
    Step('ch3', 'all', LS,
         'beyond the dissertation: every sample, bias-compensated least squares whitened by the sensor noise',
         groups=('harmonic',)),
    Step('ch3', 'all-noisy-displacement', LS,
         'beyond the dissertation: every sample, bias-compensated, whitened; 2 % noise on every sensor',
         groups=('noisy-displacement',)),
    Step('ch3-damped', 'm8', LS,
         "the dissertation's set-up: 8 sample times, noise-weighted least squares",
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8}),
    Step('ch3-damped', 'all', LS,
         'beyond the dissertation: every sample, bias-compensated least squares whitened by the sensor noise',
         groups=('harmonic',)),
    Step('ch4-case1', 'case1', PT,
         "noise-free, all 12 DOF at 0.5 rad/s; the dissertation's method",
         groups=('exact',), tests=('exact-01',)),
    Step('ch4-case1', 'case1-noisy', PT,
         'noisy; with natural-frequency equations from the free vibration (not in the dissertation)',
         groups=('noisy',), tests=('noisy-01',), options={'natural_frequencies': True}),
    Step('ch4-case1', 'case1-noisy-plain', PT,
         "noisy; the dissertation's method alone",
         groups=('noisy',), tests=('noisy-01',)),
    Step('ch4-case2', 'case2', PT,
         'noise-free, one tip sensor, 12 frequencies; with natural-frequency equations',
         groups=('exact',), options={'natural_frequencies': True}),
    Step('ch4-case2', 'case2-plain', PT,
         "noise-free, one tip sensor; the dissertation's method alone",
         groups=('exact',)),
    Step('ch4-case2', 'case2-noisy', PT,
         'noisy; with natural-frequency equations',
         groups=('noisy',), options={'natural_frequencies': True}),
    # beyond the dissertation (bench/evaluation/beyond_least_squares.py): model updating from FRFs
    Step('ch4-case2', 'case2-frf', 'updating',
         'beyond the dissertation: model updating from the FRFs of the noisy stepped sine (one tip sensor), from '
         'the postulated model; first 5 repetitions',
         groups=('noisy',), options={'data': 'frf'}, repetitions=5),
    Step('ch5-beam', 'hann', RY,
         'T = 100 s, Hann-tapered correlations (the headline)',
         groups=('impulse',)),
    Step('ch5-beam', 'plain', RY,
         'T = 100 s, plain correlations',
         groups=('impulse',), options={'window': 'rectangular'}),
    Step('ch5-beam', 'long-plain', RY,
         'T = 1200 s, plain correlations',
         groups=('impulse-long',), options={'window': 'rectangular'}),
    Step('ch5-membrane', 'single', RY,
         "one record, 1 m/s at node 5, cosine admissible functions (the dissertation's set-up)",
         groups=('initial-velocity',), options={'admissible': 'cosine'}),
    Step('ch5-membrane', 'joint', RY,
         'records started at nodes 5 and 6 together, cosine admissible functions (the headline; not in the '
         'dissertation)',
         joint=True, options={'admissible': 'cosine'}),
    # beyond the dissertation (bench/evaluation/beyond_modal.py): the modal method beside the Rayleigh quotient
    Step('ch5-beam', 'noisy', RY,
         'T = 100 s, 2 % noise on every sensor, Hann-tapered correlations',
         groups=('impulse-noisy',)),
    Step('ch5-beam', 'noisy', MD,
         'T = 100 s, 2 % noise on every sensor, SSI-cov',
         groups=('impulse-noisy',)),
    Step('ch5-membrane', 'single', MD,
         'one record, 1 m/s at node 5, SSI-cov',
         groups=('initial-velocity',)),
    Step('ch5-membrane', 'joint', MD,
         'records started at nodes 5 and 6 together, SSI-cov',
         joint=True),
    Step('ch5-damped', 'impulse', RY,
         'damped beam, impulse, 2 % noise; Hann-tapered correlations',
         groups=('impulse',)),
    Step('ch5-damped', 'impulse', MD,
         'damped beam, impulse, 2 % noise; SSI-cov on the velocities',
         groups=('impulse',), options={'quantity': 'velocity'}),
    Step('ch5-damped', 'random', MD,
         'damped beam, 8 h of unmeasured ambient force (new each repetition), 2 % noise; SSI-cov on the velocities',
         groups=('random',), options={'quantity': 'velocity'}),
)
