"""Chapter 5: natural frequencies and mode shapes by a pseudo-Rayleigh quotient.

With signals ``y_i(t)`` at the sensors, the temporal correlation matrices
``A = <y', y'^T>`` and ``B = <y, y^T>`` give the eigenvalue problem
``A v = lambda B v`` (collocation form, eq. 5.30): ``lambda = omega^2`` and
``B v`` is the mode shape at the sensors. ``y`` are displacements and ``y'``
velocities; for structures with rigid-body modes velocities and
accelerations take their place (the rigid-body velocity is constant, so its
acceleration is uncorrelated with it and the mode comes out at 0).

The temporal inner product is ``<a, b> = sum_k w_k a_k b_k / sum_k w_k`` with
trapezoid weights times a taper. ``window="hann"`` (default) tapers each
record with ``sin^2(pi t / T)``: the end effects of a finite record then
decay much faster, and on the chapter 5 beam (T = 100 s) mode 1 comes out at
-0.44 % and modes 2-6 within 0.01 %; ``window="rectangular"`` is the plain
``(1/T) int_0^T``, which leaves mode 1 at +3.9 % (1.6 periods in the record)
and modes 2-6 within 0.6 %. Several traces (tests) of one repetition are
averaged: their sums add up, as if the records were joined; with two impulse
tests at different points a pair of close modes that one impulse excites in
phase is separated.

Admissible functions (eqs. 5.16-5.25, ``admissible="cosine"``): the response
is interpolated between the sensors with the model's linear finite-element
shape functions, ``u(P, t) = sum_r w_r(t) psi_r(P)``, and the test functions
are ``g = sum_k c_k chi_k`` with ``chi_k = cos(i pi x / a) cos(j pi y / b)``
(the eigenfunctions of the free uniform rectangle, ``a``, ``b`` its sides from
the sensor locations; the ``functions`` lowest ``(i/a)^2 + (j/b)^2``),
themselves interpolated by the shape functions. Then
``int g u dD = c^T G w(t)`` with ``G = X Psi``, ``X_kr = chi_k(P_r)`` and ``Psi``
the unit-density consistent mass (Gram matrix of the shape functions), and the
quotient becomes ``(G A G^T) c = lambda (G B G^T) c``, shapes ``B G^T c``.
With as many functions as sensors this equals the collocation form (eqs.
5.24-5.25); fewer functions give a Rayleigh-Ritz reduction.

Directions the response never excites (``B`` singular, e.g. modes with a node
at the impulse) are dropped: eigen-directions of ``B`` below ``rcond`` times its
largest are left out, and ``details["rank"]`` says how many remain.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as la

from structbench.models import ModalModel, Model, ModelError, Structure

from ..errors import IdentificationError
from ..io.results import Identification
from ..io.traces import Channel, Trace

VARIANTS = ("auto", "displacement", "velocity")
WINDOWS = ("hann", "rectangular")
PAIRS = {"displacement": ("displacement", "velocity"), "velocity": ("velocity", "acceleration")}
RCOND = 1e-10


def weights(time: np.ndarray, window: str) -> np.ndarray:
    """Quadrature weights (s) of one record: trapezoid rule times the taper."""
    if window not in WINDOWS:
        raise IdentificationError(f"unknown window {window!r}; known: {', '.join(WINDOWS)}", field="window")
    dt = np.diff(time)
    w = np.zeros_like(time)
    w[:-1] += dt / 2
    w[1:] += dt / 2
    if window == "hann":
        w *= np.sin(np.pi * (time - time[0]) / (time[-1] - time[0])) ** 2
    return w


def _sensor_pairs(trace: Trace, lower: str, higher: str) -> list[tuple[Channel, Channel]]:
    sensors = trace.select(lower)
    if not sensors:
        raise IdentificationError(f"{trace.path.name}: no {lower} channels for the Rayleigh quotient",
                                  field="channels")
    return [(c, trace.channel(higher, c.node, c.direction)) for c in sensors]


def correlations(traces: Sequence[Trace], variant: str, window: str = "hann"
                 ) -> tuple[np.ndarray, np.ndarray, list[Channel]]:
    """``A = <y', y'^T>``, ``B = <y, y^T>`` (n_s, n_s) averaged over the traces,
    and the sensor channels of ``y`` (of the first trace)."""
    lower, higher = PAIRS[variant]
    pairs = _sensor_pairs(traces[0], lower, higher)
    dofs = [c.dof for c, _ in pairs]
    A = np.zeros((len(pairs), len(pairs)))
    B = np.zeros_like(A)
    total = 0.0
    for trace in traces:
        here = _sensor_pairs(trace, lower, higher)
        if [c.dof for c, _ in here] != dofs:
            raise IdentificationError(f"{trace.path.name}: its {lower} sensors differ from those of "
                                      f"{traces[0].path.name}", field="channels")
        w = weights(trace.time, window)
        y = np.column_stack([c.data for c, _ in here])
        yd = np.column_stack([d.data for _, d in here])
        A += (yd * w[:, None]).T @ yd
        B += (y * w[:, None]).T @ y
        total += w.sum()
    return A / total, B / total, [c for c, _ in pairs]


def pencil(A: np.ndarray, B: np.ndarray, rcond: float = RCOND) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of ``A v = lambda B v`` on the range of ``B`` (symmetric,
    positive semi-definite): ``lambda`` ascending (r,), ``v`` (n, r)."""
    s, U = la.eigh(B)
    keep = s > rcond * s.max()
    T = U[:, keep] / np.sqrt(s[keep])
    lam, Y = la.eigh(T.T @ A @ T)
    return lam, T @ Y


def _rigid(model: Model | None) -> bool:
    if model is None:
        return False
    if isinstance(model, ModalModel):
        return bool(np.any(model.omega == 0))
    return bool(model.modes(1).lam[0] == 0)


def choose_variant(traces: Sequence[Trace], model: Model | None, variant: str) -> str:
    """``auto``: displacement/velocity when both are logged and the model has
    no rigid-body mode, else velocity/acceleration."""
    if variant not in VARIANTS:
        raise IdentificationError(f"unknown variant {variant!r}; known: {', '.join(VARIANTS)}", field="variant")
    if variant != "auto":
        return variant
    logged = traces[0].select("displacement") and traces[0].select("velocity")
    return "displacement" if logged and not _rigid(model) else "velocity"


def cosine_functions(locations: np.ndarray, count: int) -> np.ndarray:
    """``cos(i pi x / a) cos(j pi y / b)`` at the points (n, 3), the ``count``
    lowest by ``(i/a)^2 + (j/b)^2``; shape (count, n). ``a``, ``b`` are the
    extents of the points (a zero extent drops that coordinate)."""
    xy = locations[:, :2] - locations[:, :2].min(axis=0)
    side = xy.max(axis=0)
    orders = [range(count) if s > 0 else range(1) for s in side]
    pairs = sorted(((i, j) for i in orders[0] for j in orders[1]),
                   key=lambda ij: (sum((k / s) ** 2 for k, s in zip(ij, side) if s > 0), ij))[:count]
    arg = [np.outer([ij[d] for ij in pairs], xy[:, d] / side[d]) if side[d] > 0 else 0.0 for d in range(2)]
    return np.cos(np.pi * arg[0]) * np.cos(np.pi * arg[1])


def shape_gram(model: Structure, sensors: list[Channel]) -> np.ndarray:
    """Gram matrix ``int psi_r psi_s dD`` of the model's shape functions over
    the sensor DOF (unit-density consistent mass), (n_s, n_s); every DOF of the
    model must carry a sensor."""
    unit = np.where(model.kind_mask(("mass",)), 1.0, model.values)
    mass = model.mass(unit).toarray()
    index = []
    for c in sensors:
        try:
            index.append(model.dof_index(c.node, c.direction))
        except ModelError:
            raise IdentificationError(f"sensor {c.name} is not at a free DOF of model {model.name}",
                                      field="model") from None
    missing = sorted(set(range(model.n_dof)) - set(index))
    if missing:
        names = ", ".join(f"({n}, {d})" for n, d in (model.dofs[i] for i in missing))
        raise IdentificationError(f"the finite-element interpolation needs a sensor at every DOF of "
                                  f"{model.name}; missing {names}", field="channels")
    return mass[np.ix_(index, index)]


def _normalised(shapes: np.ndarray) -> np.ndarray:
    """Columns scaled to max |.| = 1 with the largest entry positive."""
    peak = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
    return shapes / np.where(peak == 0, 1.0, peak)


def identify(traces: Sequence[Trace], model: Model | None = None, variant: str = "auto",
             window: str = "hann", admissible: str | None = None, functions: int | None = None,
             rcond: float = RCOND) -> Identification:
    """Natural frequencies (rad/s) and mode shapes at the sensors from the
    free (or any stationary) response in the traces of one repetition."""
    chosen = choose_variant(traces, model, variant)
    A, B, sensors = correlations(traces, chosen, window)
    if admissible is None:
        G = np.eye(len(sensors))
    elif admissible == "cosine":
        if not isinstance(model, Structure):
            raise IdentificationError("admissible functions need a finite-element model for the "
                                      "interpolation (--model)", field="model")
        count = functions or len(sensors)
        locations = np.array([c.location for c in sensors])
        if not np.all(np.isfinite(locations)):
            locations = np.array([np.pad(model.nodes[c.node], (0, 3))[:3] for c in sensors])
        G = cosine_functions(locations, count) @ shape_gram(model, sensors)
    else:
        raise IdentificationError(f"unknown admissible functions {admissible!r}; known: cosine",
                                  field="admissible")
    lam, vec = pencil(G @ A @ G.T, G @ B @ G.T, rcond)
    lam = np.where(np.abs(lam) <= 1e-9 * np.abs(lam).max(), 0.0, lam)
    shapes = _normalised(B @ G.T @ vec)
    return Identification(
        method="rayleigh", structure=model.name if model is not None else traces[0].structure,
        repetition=traces[0].repetition, tests=[t.test for t in traces],
        omega=np.sqrt(np.maximum(lam, 0.0)).tolist(), eigenvalues=lam.tolist(),
        mode_shapes=shapes.T.tolist(), sensors=[c.name for c in sensors],
        details={"variant": chosen, "window": window, "admissible": admissible or "collocation",
                 "functions": G.shape[0], "rank": int(lam.size),
                 "record_s": [float(t.time[-1] - t.time[0]) for t in traces]})
