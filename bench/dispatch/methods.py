"""The identification methods by name, with their options and defaults.

A :class:`Method` wraps an identifier's ``identify(traces, model, **options)``
(``traces``: the :class:`~structbench.identifier.io.traces.Trace` records of one
run; ``model``: the model with the unknown parameters, or None) returning an
:class:`~structbench.identifier.io.results.Identification`.

Besides the built-ins, every entry point of the group
``structbench.identifiers`` is a method (docs/plugins.md): its name is the
entry point's, it loads to a callable of the same signature returning an
``Identification`` or a run dict of docs/results-format.md, with optional
attributes ``defaults`` (dict), ``help`` (str), ``model``, ``choices`` and
``channels`` (str: the trace channels and tests it needs).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Any

from structbench.identifier import least_squares, modal, perturbation, rayleigh, updating
from structbench.identifier.modal import close_pairs
from structbench.identifier.errors import IdentificationError
from structbench.identifier.io.results import Identification


@dataclass(frozen=True)
class Method:
    """An identification method: ``call(traces, model, **options)``;
    ``defaults`` lists every option it takes, ``choices`` the allowed values
    of some; ``model``: "required",
    "optional" or "none"; ``postulated``: the method starts from a prior
    (starting values): without ``--prior``/``prior=``/a campaign ``[prior]``
    it gets the structure's ``-postulated`` variant when there is one, else
    an error (never the traces' structure's values, the truth); the others
    get the structure's topology (runs.resolve_prior). ``channels``: the
    trace channels and tests the method needs, in words."""

    name: str
    call: Callable[..., Identification]
    defaults: Mapping[str, Any]
    help: str
    choices: Mapping[str, tuple[Any, ...]] = field(default_factory=dict)
    model: str = "required"
    postulated: bool = False
    channels: str = "not stated"

    def options(self, given: Mapping[str, Any]) -> dict[str, Any]:
        """The defaults updated with ``given`` (None means default); an unknown
        option is an error naming it."""
        unknown = sorted(set(given) - set(self.defaults))
        if unknown:
            raise IdentificationError(f"unknown option(s) {unknown} for method {self.name}; it takes "
                                      f"{', '.join(self.defaults) or 'none'}", field="options")
        chosen = {k: (given[k] if given.get(k) is not None else v) for k, v in self.defaults.items()}
        for key, allowed in self.choices.items():
            if chosen[key] not in allowed:
                raise IdentificationError(f"{chosen[key]!r} is not one of {', '.join(map(str, allowed))}",
                                          field=key)
        return chosen


BUILTIN: dict[str, Method] = {m.name: m for m in (
    Method("least-squares", least_squares.identify,
           {"estimator": "bias-compensated", "samples": None, "interval": 0.5, "integration": "auto",
            "weighting": "noise", "domain": "auto"},
           "chapter 3: element mass, damping and stiffness by least squares on the equations of motion",
           {"estimator": least_squares.ESTIMATORS, "integration": least_squares.INTEGRATIONS,
            "weighting": least_squares.WEIGHTINGS, "domain": least_squares.DOMAINS},
           channels="the force at every forced DOF and one of displacement, velocity or acceleration at every "
                    "DOF of the model (any mix; any excitation), or at some DOF only from a broadband test "
                    "(random, impulse, several stepped-sine lines: unmeasured DOF condensed, frequency domain)"),
    Method("perturbation", perturbation.identify,
           {"max_iterations": 20, "tol": 1e-8, "natural_frequencies": False},
           "chapter 4: iterative frequency-domain perturbation from a postulated model", postulated=True,
           channels="harmonic (stepped-sine) tests: the force and one response quantity (displacement, "
                    "velocity or acceleration) at one or more DOF; unmeasured DOF are pseudo-parameters"),
    Method("rayleigh", rayleigh.identify,
           {"variant": "auto", "window": "hann", "admissible": None, "functions": None},
           "chapter 5: modes from free response by a pseudo-Rayleigh quotient",
           {"variant": rayleigh.VARIANTS, "window": rayleigh.WINDOWS, "admissible": (None, "cosine")},
           model="optional",
           channels="free responses: displacement and velocity (variant displacement) or velocity and "
                    "acceleration (variant velocity) at the same sensors"),
    Method("modal", modal.identify,
           {"quantity": "auto", "block_rows": None, "max_order": 80, "references": 20, "segments": 8,
            "min_fraction": 0.3, "refine": "auto", "uncertainty": "jackknife", "input": "auto", "short_lags": "on"},
           "output-only or free-decay modes with damping: SSI-cov, automatic order selection, jackknife errors",
           {"quantity": modal.QUANTITIES, "refine": close_pairs.REFINE, "uncertainty": modal.UNCERTAINTY,
            "input": modal.input_output.INPUTS, "short_lags": modal.SHORT_LAGS},
           model="optional",
           channels="one or more response channels of any quantity (displacement, velocity, acceleration, "
                    "mixed; weighted by their noise); a free decay or a random response; a measured force "
                    "with a response at its DOF adds unit-modal-mass shapes (option input)"),
    Method("updating", updating.identify, dict(updating.DEFAULTS),
           "finite-element model updating from identified modes (a modal results or modal-data file, "
           "--option modal=FILE) starting from the model given as the prior", postulated=True,
           channels="no channels: identified modes (a modal results file, a modal-data file or UFF 55) at "
                    "the model's DOF"),
)}


GROUP = "structbench.identifiers"


def _as_result(value: Any, name: str) -> Identification:
    """A plugin's return value as an Identification (a run dict is checked)."""
    if isinstance(value, Identification):
        return value
    if not isinstance(value, Mapping):
        raise IdentificationError(f"plugin returned {type(value).__name__}, not a run of docs/results-format.md",
                                  field=name)
    try:
        return Identification.from_dict(dict(value))
    except TypeError as err:
        raise IdentificationError(f"plugin returned a run that is not in docs/results-format.md: {err}",
                                  field=name) from None


def _broken(name: str, error: Exception) -> Callable[..., Identification]:
    def call(*_: Any, **__: Any) -> Identification:
        raise IdentificationError(f"the plugin failed to load: {type(error).__name__}: {error}", field=name)
    return call


def plugin(entry: Any) -> Method:
    """The method of one entry point (a plugin that fails to load gives a
    method that reports why when used)."""
    try:
        target = entry.load()
    except Exception as err:  # any import error of third-party code
        return Method(entry.name, _broken(entry.name, err), {}, f"plugin {entry.value} (failed to load)", model="none")

    def call(traces: list, model: Any, **options: Any) -> Identification:
        return _as_result(target(traces, model, **options), entry.name)

    doc = (getattr(target, "__doc__", None) or "").strip().splitlines()
    return Method(entry.name, call, dict(getattr(target, "defaults", {})),
                  str(getattr(target, "help", doc[0] if doc else f"plugin {entry.value}")),
                  {k: tuple(v) for k, v in getattr(target, "choices", {}).items()},
                  str(getattr(target, "model", "optional")), bool(getattr(target, "postulated", False)),
                  str(getattr(target, "channels", "not stated")))


def methods() -> dict[str, Method]:
    """Every method known by name: the built-ins, then the plugins (a plugin
    cannot replace a built-in)."""
    found = {e.name: plugin(e) for e in entry_points(group=GROUP) if e.name not in BUILTIN}
    return dict(BUILTIN) | dict(sorted(found.items()))


def method(name: str) -> Method:
    """The method called ``name``; an unknown name is an error listing the known ones."""
    known = methods()
    if name not in known:
        raise IdentificationError(f"unknown method {name!r}; known: {', '.join(known)}", field="--method")
    return known[name]
