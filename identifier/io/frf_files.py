"""Frequency response functions and their HDF5 file (``docs/frf-format.md``).

An :class:`Frf` holds the FRFs of several response channels per one force
over ``m`` frequency lines: ``frf`` (c, m) complex in SI units per newton,
the ordinary coherence (c, m), the normalized random error and the
confidence bands of magnitude and phase (2, c, m), and the averaged auto and
cross spectra they were computed from. :func:`write_frf` and
:func:`read_frf` store it as ``structbench-frf`` version 1; the reader
checks every dataset's shape and dtype and names the file and dataset of
what it refuses.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..errors import IdentificationError

FORMAT = "structbench-frf"
FORMAT_VERSION = 1
_INFO = ("name", "quantity", "unit", "node", "direction")


@dataclass(frozen=True)
class ChannelInfo:
    """A channel an FRF refers to: trace name, quantity, SI unit, node, direction."""

    name: str
    quantity: str
    unit: str
    node: int
    direction: str


def frf_unit(response: str, force: str) -> str:
    """The FRF's unit ``response/force``, compound units in parentheses:
    ``m/N``, ``(m/s)/N``, ``(m/s^2)/N``, ``rad/(N m)``."""
    def wrap(unit: str) -> str:
        return f"({unit})" if ("/" in unit or " " in unit) else unit
    return f"{wrap(response)}/{wrap(force)}"


@dataclass
class Frf:
    """FRFs of ``responses`` (c channels) per ``force`` over ``m`` lines.

    ``frequency`` (m,) Hz; ``frf`` (c, m) complex, ``H = X / F`` with the
    time dependence ``exp(+i omega t)`` (a response lagging the force has a
    negative phase); ``coherence`` (c, m) in [0, 1]; ``random_error`` (c, m)
    the normalized random error (relative standard deviation of ``|H|``,
    equal to the standard deviation of the phase in rad); ``magnitude_band``
    and ``phase_band`` (2, c, m) lower and upper bounds at ``confidence``
    (phase in rad, NaN where undefined); ``n_averages`` (m,) averages per
    line and ``n_effective`` (m,) the independent averages they are worth;
    ``auto_force`` (m,), ``auto_response`` (c, m) and ``cross`` (c, m)
    the averaged products ``<|F|^2>``, ``<|X|^2>``, ``<conj(F) X>`` (scaled
    as stated by ``spectra_scaling``).
    """

    frequency: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    random_error: np.ndarray
    magnitude_band: np.ndarray
    phase_band: np.ndarray
    n_averages: np.ndarray
    n_effective: np.ndarray
    auto_force: np.ndarray
    auto_response: np.ndarray
    cross: np.ndarray
    force: ChannelInfo
    responses: list[ChannelInfo]
    estimator: str
    analysis: str
    window: str
    segment: int
    overlap: float
    confidence: float
    dt: float
    spectra_scaling: str
    attrs: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def omega(self) -> np.ndarray:
        """Circular frequencies (m,), rad/s."""
        return 2.0 * np.pi * self.frequency

    @property
    def magnitude(self) -> np.ndarray:
        """``|H|`` (c, m) in :attr:`units`."""
        return np.abs(self.frf)

    @property
    def phase(self) -> np.ndarray:
        """``arg H`` (c, m), rad in (-pi, pi]."""
        return np.angle(self.frf)

    @property
    def units(self) -> list[str]:
        """Each response's FRF unit (``(m/s^2)/N`` ...)."""
        return [frf_unit(r.unit, self.force.unit) for r in self.responses]

    def index(self, name: str) -> int:
        """Row of the response channel ``name``; an error listing the names if absent."""
        for i, r in enumerate(self.responses):
            if r.name == name:
                return i
        raise IdentificationError(f"no FRF of {name!r} (responses: {', '.join(r.name for r in self.responses)})",
                                  field="responses")


_ARRAYS = {  # dataset -> (attribute of Frf, dims, dtype kind, unit)
    "frequency": ("frequency", "m", "f", "Hz"), "omega": (None, "m", "f", "rad/s"),
    "frf": ("frf", "cm", "c", None), "coherence": ("coherence", "cm", "f", "1"),
    "random_error": ("random_error", "cm", "f", "1"), "magnitude_band": ("magnitude_band", "2cm", "f", None),
    "phase_band": ("phase_band", "2cm", "f", "rad"), "n_averages": ("n_averages", "m", "i", "1"),
    "n_effective": ("n_effective", "m", "f", "1"), "spectra/force": ("auto_force", "m", "f", None),
    "spectra/response": ("auto_response", "cm", "f", None), "spectra/cross": ("cross", "cm", "c", None),
}
_SCALARS = ("estimator", "analysis", "window", "segment", "overlap", "confidence", "dt", "spectra_scaling")


def _software() -> str:
    try:
        return f"structbench {version('structbench')}"
    except PackageNotFoundError:
        return "structbench"


def write_frf(path: str | Path, frf: Frf) -> Path:
    """Write ``frf`` to ``path`` (HDF5, ``docs/frf-format.md``); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    with h5py.File(tmp, "w", track_order=True) as f:
        f.attrs.update({"format": FORMAT, "format_version": FORMAT_VERSION, "software": _software()})
        for key in _SCALARS:
            f.attrs[key] = getattr(frf, key)
        f.attrs["warnings"] = json.dumps(frf.warnings)
        for key, value in frf.attrs.items():
            f.attrs[key] = json.dumps(value) if isinstance(value, (list, dict)) else value
        for key, (attr, _, _, unit) in _ARRAYS.items():
            data = frf.omega if attr is None else getattr(frf, attr)
            ds = f.create_dataset(key, data=data)
            if unit is not None:
                ds.attrs["unit"] = unit
        units = frf.units
        f["frf"].attrs["units"] = json.dumps(units)
        f["magnitude_band"].attrs["units"] = json.dumps(units)
        force = f.create_group("force")
        force.attrs.update({k: getattr(frf.force, k) for k in _INFO})
        table = f.create_group("responses")
        for k in _INFO:
            values = [getattr(r, k) for r in frf.responses]
            table.create_dataset(k, data=np.asarray(values, dtype=np.int64) if k == "node"
                                 else np.asarray(values, dtype=h5py.string_dtype()), shape=(len(values),))
    tmp.replace(path)
    return path


def _fail(path: Path, what: str, field: str) -> IdentificationError:
    return IdentificationError(f"{path.name}: {what}", field=field)


def _dataset(f: h5py.File, path: Path, key: str, dims: str, kind: str, c: int, m: int) -> np.ndarray:
    if not isinstance(f.get(key), h5py.Dataset):
        raise _fail(path, f"missing dataset /{key}", key)
    data = f[key][()]
    shape = tuple({"m": m, "c": c, "2": 2}[d] for d in dims)
    if data.shape != shape or np.dtype(data.dtype).kind not in (kind + ("i" if kind == "f" else "")):
        raise _fail(path, f"/{key} is {data.dtype} {data.shape}, expected {shape} "
                          f"{ {'f': 'real', 'c': 'complex', 'i': 'integer'}[kind]}", key)
    return data


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _attr(value: Any) -> Any:
    """An attribute as Python data: JSON lists and objects decoded."""
    if isinstance(value, (str, bytes)):
        text = _text(value)
        return json.loads(text) if text[:1] in ("[", "{") else text
    return np.asarray(value).tolist()


def read_frf(path: str | Path) -> Frf:
    """Read an FRF file; an :class:`IdentificationError` names the file and
    the dataset or attribute that is missing or has the wrong shape."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            if _text(f.attrs.get("format", "")) != FORMAT:
                raise _fail(path, f"root attribute 'format' is {f.attrs.get('format')!r}, expected {FORMAT!r}",
                            "format")
            for key in ("frequency", "responses/name", "force"):
                if key not in f:
                    raise _fail(path, f"missing /{key}", key)
            m, c = f["frequency"].shape[0], f["responses/name"].shape[0]
            arrays = {attr: _dataset(f, path, key, dims, kind, c, m)
                      for key, (attr, dims, kind, _) in _ARRAYS.items() if attr is not None}
            responses = [ChannelInfo(*(_text(f[f"responses/{k}"][i]) if k != "node" else int(f["responses/node"][i])
                                       for k in _INFO)) for i in range(c)]
            fa = f["force"].attrs
            missing = [k for k in _INFO if k not in fa]
            if missing:
                raise _fail(path, f"/force has no attribute {missing[0]!r}", missing[0])
            force = ChannelInfo(*(int(fa[k]) if k == "node" else _text(fa[k]) for k in _INFO))
            scalars = {}
            for key in _SCALARS:
                if key not in f.attrs:
                    raise _fail(path, f"missing root attribute {key!r}", key)
                value = f.attrs[key]
                scalars[key] = _text(value) if isinstance(value, (str, bytes)) else value.item()
            known = {"format", "format_version", "software", "warnings", *_SCALARS}
            attrs = {k: _attr(v) for k, v in f.attrs.items() if k not in known}
            warnings = json.loads(_text(f.attrs.get("warnings", "[]")))
    except IdentificationError:
        raise
    except (OSError, KeyError, ValueError) as err:
        raise IdentificationError(f"cannot read FRF file: {err}", field=str(path)) from None
    arrays["n_averages"] = arrays["n_averages"].astype(np.int64)
    return Frf(**arrays, force=force, responses=responses, attrs=attrs, warnings=warnings, **scalars)
