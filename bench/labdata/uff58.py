"""Universal File Format dataset 58 (function at nodal DOF), ASCII and binary.

A UFF file is a sequence of datasets, each between two lines ``    -1``; the
line after the opening one holds the dataset type (I6). Dataset 58 has 11
header lines (records 2-11 of the published layout, record 1 being 5 ID
lines) and the data values (record 12):

- record 6 ``2(I5,I10),2(1X,10A1,I10,I4)``: function type (1 = time
  response), function id, version, load case, response entity name, node,
  direction (1..3 = +X..+Z translation, 4..6 = rotations, negative = minus),
  reference entity name, node, direction;
- record 7 ``3I10,3E13.5``: ordinate data type (2 real single, 4 real double,
  5/6 complex), number of values, abscissa spacing (1 even, 0 uneven),
  abscissa minimum, increment, z-axis value;
- records 8-11 ``I10,3I5,2(1X,20A1)``: abscissa, ordinate, ordinate
  denominator and z-axis: specific data type (8 displacement, 11 velocity,
  12 acceleration, 9/13 force, 17 time), length, force and temperature
  exponents, axis label, axis units label;
- record 12: even spacing ``Y1 Y2 ...``, uneven ``X1 Y1 X2 Y2 ...``; ASCII
  single precision ``6E13.5``, double ``4E20.12`` (uneven ``2(E13.5,E20.12)``);
  complex data (spectra, FRFs) as real and imaginary parts, uneven ``X1 RE1 IM1 ...``
  (binary: all in the ordinate's precision, as pyuff writes them).

Binary 58 (``58b``): the type line reads ``(I6,1A1,I6,I6,I12,I12,...)`` =
58, ``b``, byte order (1 little, 2 big endian), floating-point format (2 =
IEEE 754), ASCII header lines (11), bytes of data; the data follow the last
header line directly, values in the ordinate's precision (the abscissa of
uneven data too, as pyuff writes it), then ``    -1``. The byte count is taken
from record 7 (pyuff writes a wrong header count for uneven data), so a
``    -1`` inside the binary data cannot end the dataset early.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from structbench.models.errors import UserError

_END = re.compile(rb"^ *-1 *\r?$", re.M)
_WIDTH = {2: 13, 4: 20, 5: 13, 6: 20}           # ASCII field width of an ordinate value (or part)
_DTYPE = {2: "f4", 4: "f8", 5: "f4", 6: "f8"}   # binary item of an ordinate value (or part)
FUNCTION_TYPES = {0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum",
                  4: "frequency response function", 6: "coherence", 9: "power spectral density"}


@dataclass(frozen=True)
class Axis:
    """Records 8-11: specific data type, (length, force, temperature)
    exponents, axis label and axis units label (``""`` for ``NONE``)."""

    data_type: int = 0
    exponents: tuple[int, int, int] = (0, 0, 0)
    label: str = ""
    units: str = ""


@dataclass(frozen=True)
class Record58:
    """One dataset 58: ``index`` is its 1-based position among the file's
    datasets; ``x`` (n,) the abscissa and ``y`` (n,) the ordinate as written
    (complex for ordinate data types 5 and 6); ``denominator`` record 10."""

    index: int
    id_lines: tuple[str, str, str, str, str]
    function_type: int
    node: int
    direction: int
    reference_node: int
    reference_direction: int
    abscissa: Axis
    ordinate: Axis
    x: np.ndarray
    y: np.ndarray
    binary: bool = False
    ordinate_type: int = 4
    even: bool = True
    denominator: Axis = Axis()


class _Reader:
    def __init__(self, path: Path):
        self.path, self.data, self.pos, self.index = path, path.read_bytes(), 0, 0
        self.axes: dict[tuple[float, float, int], np.ndarray] = {}

    def fail(self, message: str, record: int | None = None) -> UserError:
        where = f"{self.path.name} dataset {self.index}" + (f" record {record}" if record else "")
        return UserError(message, field=where)

    def line(self, record: int | None = None) -> str:
        if self.pos >= len(self.data):
            raise self.fail("the file ends inside the dataset (truncated)", record)
        end = self.data.find(b"\n", self.pos)
        end = len(self.data) if end < 0 else end
        text = self.data[self.pos:end].rstrip(b"\r").decode("latin-1")
        self.pos = end + 1
        return text

    def even_axis(self, start: float, step: float, count: int) -> np.ndarray:
        """``start + k step``, k < count: one shared (read-only) array per
        distinct axis of the file, so channels on the same axis compare by identity."""
        key = (start, step, count)
        if key not in self.axes:
            self.axes[key] = start + np.arange(count) * step
            self.axes[key].flags.writeable = False
        return self.axes[key]

    def at_end(self) -> bool:
        while self.pos < len(self.data) and self.data[self.pos:self.pos + 1] in b" \t\r\n":
            self.pos += 1
        return self.pos >= len(self.data)

    def skip_dataset(self) -> None:
        found = _END.search(self.data, self.pos)
        if found is None:
            raise self.fail("no closing '    -1' (truncated)")
        self.pos = found.end()


def _int(reader: _Reader, text: str, record: int, name: str) -> int:
    try:
        return int(text.strip() or 0)
    except ValueError:
        raise reader.fail(f"{name} is {text.strip()!r}, not an integer", record) from None


def _float(reader: _Reader, text: str, record: int, name: str) -> float:
    try:
        return float(text.strip().replace("D", "E").replace("d", "e") or 0.0)
    except ValueError:
        raise reader.fail(f"{name} is {text.strip()!r}, not a number", record) from None


def _axis(reader: _Reader, text: str, record: int) -> Axis:
    text = text.ljust(67)
    label, units = text[26:46].strip(), text[47:67].strip()
    return Axis(_int(reader, text[0:10], record, "specific data type"),
                tuple(_int(reader, text[a:a + 5], record, "units exponent") for a in (10, 15, 20)),
                "" if label.upper() == "NONE" else label, "" if units.upper() == "NONE" else units)


def _ascii_values(reader: _Reader, chunk: bytes, widths: tuple[int, ...], count: int) -> list[np.ndarray]:
    """``count`` groups of fixed-width fields from the lines of ``chunk``
    (whole groups per line; blanks past the last group are ignored)."""
    group = sum(widths)
    lines = chunk.replace(b"\r", b"").split(b"\n")
    flat = b"".join(ln[:len(ln) // group * group] for ln in lines).replace(b"D", b"E").replace(b"d", b"e")
    if len(flat) < count * group:
        raise reader.fail(f"holds {len(flat) // group} of the {count} values that record 7 announces "
                          "(truncated?)", 12)
    fields = np.frombuffer(flat[:count * group], dtype=[(f"f{i}", f"S{w}") for i, w in enumerate(widths)])
    try:
        return [fields[f"f{i}"].astype(np.float64) for i in range(len(widths))]
    except ValueError as err:
        raise reader.fail(f"a value is not a number ({err})", 12) from None


def _binary_values(reader: _Reader, dtype: np.dtype, count: int) -> np.ndarray:
    """The values as float64: a read-only view into the file's bytes when they
    are native doubles (no copy), else converted."""
    size = count * dtype.itemsize
    start = reader.pos
    if len(reader.data) - start < size:
        raise reader.fail(f"holds {len(reader.data) - start} of the {size} bytes that record 7 announces "
                          "(truncated)", 12)
    reader.pos += size
    if reader.at_end() or reader.line(12).strip() != "-1":
        raise reader.fail(f"no closing '    -1' after the {size} bytes of binary data", 12)
    return np.frombuffer(reader.data, dtype=dtype, count=count, offset=start).astype(np.float64, copy=False)


def _record(reader: _Reader, type_line: str) -> Record58:
    binary = type_line[6:7].lower() == "b"
    order = _int(reader, type_line[7:13], 1, "byte ordering") if binary else 1
    if binary and (order not in (1, 2) or _int(reader, type_line[13:19], 1, "floating-point format") != 2):
        raise reader.fail("binary data must be IEEE 754 (format 2) little (1) or big (2) endian", 1)
    ids = tuple(reader.line(1).strip() for _ in range(5))
    r6 = reader.line(6).ljust(80)
    r7 = reader.line(7).ljust(69)
    ordinate_type = _int(reader, r7[0:10], 7, "ordinate data type")
    count = _int(reader, r7[10:20], 7, "number of values")
    even = _int(reader, r7[20:30], 7, "abscissa spacing") == 1
    start, step = _float(reader, r7[30:43], 7, "abscissa minimum"), _float(reader, r7[43:56], 7, "abscissa increment")
    axes = [_axis(reader, reader.line(r), r) for r in (8, 9, 10, 11)]
    if ordinate_type not in _WIDTH:
        raise reader.fail(f"ordinate data type {ordinate_type}: 2 (real single), 4 (real double), 5 (complex "
                          "single) or 6 (complex double)", 7)
    if count < 2:
        raise reader.fail(f"{count} values: a record needs at least two", 7)
    if even and not step > 0:
        raise reader.fail(f"even spacing with abscissa increment {step:g}: no time axis (nor frequency axis)", 7)
    complex_ = ordinate_type in (5, 6)
    per_point = (1 if even else 2) + complex_  # [x,] y or [x,] re, im
    if binary:
        values = _binary_values(reader, np.dtype(("<" if order == 1 else ">") + _DTYPE[ordinate_type]),
                                count * per_point)
        columns = [values] if per_point == 1 else list(values.reshape(count, per_point).T)
    else:
        found = _END.search(reader.data, reader.pos)
        if found is None:
            raise reader.fail("no closing '    -1' (truncated)", 12)
        chunk, reader.pos = reader.data[reader.pos:found.start()], found.end()
        width = _WIDTH[ordinate_type]
        widths = ((width,) if even else (13, width)) + ((width,) if complex_ else ())
        columns = _ascii_values(reader, chunk, widths, count)
    x = reader.even_axis(start, step, count) if even else columns[0]
    y = columns[-2] + 1j * columns[-1] if complex_ else columns[-1]
    return Record58(reader.index, ids, _int(reader, r6[0:5], 6, "function type"),
                    _int(reader, r6[41:51], 6, "response node"), _int(reader, r6[51:55], 6, "response direction"),
                    _int(reader, r6[66:76], 6, "reference node"), _int(reader, r6[76:80], 6, "reference direction"),
                    axes[0], axes[1], x, y, binary, ordinate_type, even, axes[2])


@dataclass(frozen=True)
class Dataset:
    """A dataset other than 58: its 1-based ``index`` among the file's
    datasets, its ``kind`` (type number) and its lines after the type line."""

    index: int
    kind: int
    lines: tuple[str, ...]


def read_datasets(path: str | Path) -> tuple[list[Record58], list[Dataset]]:
    """Every dataset 58 of a UFF file, parsed, and every other dataset as
    text lines; a malformed file raises :class:`UserError` naming the dataset
    and record."""
    reader = _Reader(Path(path))
    records, others = [], []
    while not reader.at_end():
        reader.index += 1
        opening = reader.line()
        if opening.strip() != "-1":
            raise reader.fail(f"expected the opening '    -1', found {opening[:20]!r}")
        type_line = reader.line()
        kind = _int(reader, type_line[0:6], 1, "dataset type")
        if kind == 58:
            records.append(_record(reader, type_line))
        else:
            start = reader.pos
            reader.skip_dataset()
            body = reader.data[start:reader.pos].decode("latin-1").splitlines()
            others.append(Dataset(reader.index, kind, tuple(body[:-1])))
    return records, others


def read_uff58(path: str | Path) -> list[Record58]:
    """Every dataset 58 of a UFF file (other datasets, e.g. 15 or 164, are
    skipped); a malformed file raises :class:`UserError` naming the dataset
    and record."""
    records, others = read_datasets(path)
    if not records:
        raise UserError(f"no dataset 58 (found types: {', '.join(str(d.kind) for d in others) or 'none'})",
                        field=Path(path).name)
    return records


def _axis_line(axis: Axis) -> str:
    return (f"{axis.data_type:10d}" + "".join(f"{e:5d}" for e in axis.exponents)
            + f" {axis.label or 'NONE':<20.20s} {axis.units or 'NONE':<20.20s}\n")


def record_bytes(record: Record58, binary: bool) -> bytes:
    """One dataset 58 (real double precision) in the published layout;
    ``record.even`` chooses even spacing (``x[0]`` and ``x[1] - x[0]`` in the
    header, E13.5) or the abscissa values in record 12."""
    n = record.y.size
    dx = float(record.x[1] - record.x[0]) if record.even else 0.0
    x0 = float(record.x[0]) if record.even else 0.0
    values = record.y if record.even else np.column_stack([record.x, record.y]).ravel()
    order = 1 if np.little_endian else 2
    head = (f"{-1:6d}\n{58:6d}" + (f"b{order:6d}{2:6d}{11:12d}{values.size * 8:12d}{0:6d}{0:6d}{0:12d}{0:12d}\n"
                                   if binary else "\n"))
    head += "".join(f"{(line or 'NONE')[:80]:<80s}\n" for line in record.id_lines)
    head += (f"{record.function_type:5d}{0:10d}{0:5d}{0:10d} {'NONE':>10s}{record.node:10d}{record.direction:4d}"
             f" {'NONE':>10s}{record.reference_node:10d}{record.reference_direction:4d}\n")
    head += f"{4:10d}{n:10d}{int(record.even):10d}{x0:13.5E}{dx:13.5E}{0.0:13.5E}\n"
    head += _axis_line(record.abscissa) + _axis_line(record.ordinate) + _axis_line(Axis()) + _axis_line(Axis())
    if binary:
        body = np.ascontiguousarray(values, dtype="=f8").tobytes()
    elif record.even:
        body = _lines(values, "%20.12E", 4)
    else:
        body = _lines(values, "%13.5E%20.12E", 2)
    return head.encode("latin-1") + body + f"{-1:6d}\n".encode()


def _lines(values: np.ndarray, fmt: str, per_line: int) -> bytes:
    """ASCII record 12: ``per_line`` groups of ``fmt`` per line."""
    groups = fmt.count("%")
    full = values.size // (groups * per_line) * groups * per_line
    text = ((fmt * per_line + "\n") * (full // (groups * per_line))) % tuple(values[:full].tolist())
    rest = values[full:]
    if rest.size:
        text += (fmt * (rest.size // groups) + "\n") % tuple(rest.tolist())
    return text.encode()


def write_uff58(path: str | Path, records: list[Record58], binary: bool) -> None:
    """Write datasets 58 to a new file (ASCII or binary)."""
    Path(path).write_bytes(b"".join(record_bytes(r, binary) for r in records))
