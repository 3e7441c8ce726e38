"""Import throughput: a UFF 58 binary file of 100 channels x 360,000 samples
(1 h at 100 Hz, 288 MB of doubles) into a trace folder.

The file is written first (structbench's UFF writer, accelerations in g on
nodes 1..100, +Z); only ``structbench.import_data`` is timed: reading and
checking the datasets, converting g to m/s^2 and writing the HDF5 trace
atomically. Two cases: clean labels, and duplicated labels (the fourth
channel mislabelled node 1 at acquisition) imported with a sensor map that
moves dataset 4 to node 4 (the import without the map fails first: its
time is printed too). Prints the file size, the wall-clock and CPU time
(the machine may be shared: CPU time is the steadier figure) and the
throughput.

    python benchmarks/import_throughput.py [CHANNELS SAMPLES]
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import structbench as sb
from structbench.labdata.uff58 import Axis, Record58, write_uff58


def write_file(path: Path, channels: int, samples: int, duplicate: int | None = None) -> None:
    """``channels`` accelerations in g on nodes 1..channels (+Z); channel
    ``duplicate`` (1-based), if given, is labelled node 1 instead."""
    rng = np.random.default_rng(0)
    time_axis = np.arange(samples) * 0.01
    records = [Record58(i + 1, (f"A{i + 1}", "NONE", "NONE", "NONE", "NONE"), 1,
                        1 if i + 1 == duplicate else i + 1, 3, 1, 3,
                        Axis(17, (0, 0, 0), "Time", "s"), Axis(12, (0, 0, 0), "Acceleration", "g"),
                        time_axis, rng.standard_normal(samples), True)
               for i in range(channels)]
    write_uff58(path, records, binary=True)


def timed(call) -> tuple[object, float, float]:
    """(result or the exception raised, wall s, CPU s of this process)."""
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        result = call()
    except sb.UserError as err:
        result = err
    return result, time.perf_counter() - wall, time.process_time() - cpu


def main(channels: int = 100, samples: int = 360_000) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        source = Path(tmp) / "hour.uff"
        write_file(source, channels, samples)
        size = source.stat().st_size
        written, seconds, cpu = timed(lambda: sb.import_data([source], Path(tmp) / "lab"))
        print(f"{channels} channels x {samples} samples, UFF 58 binary {size / 1e6:.0f} MB -> "
              f"{written[0].stat().st_size / 1e6:.0f} MB HDF5: import {seconds:.2f} s wall, {cpu:.2f} s CPU "
              f"({size / 1e6 / seconds:.0f} MB/s; target < 10 s)")
        source.unlink()
        twice = Path(tmp) / "twice.uff"
        write_file(twice, channels, samples, duplicate=4)
        error, seconds, cpu = timed(lambda: sb.import_data([twice], Path(tmp) / "lab-twice"))
        assert isinstance(error, sb.UserError), "duplicated labels must fail without a map"
        print(f"duplicated labels, no map: error after {seconds:.2f} s wall, {cpu:.2f} s CPU")
        map_file = Path(tmp) / "map.toml"
        map_file.write_text('[[channels]]\nfile = "twice.uff"\ndataset = 4\nnode = 4\n')
        notes: list[str] = []
        written, seconds, cpu = timed(lambda: sb.import_data([twice], Path(tmp) / "lab-mapped", map_file,
                                                             report=notes.append))
        assert notes == ["twice.uff dataset 4 ('A4'): node 1 -> 4 (sensor map channels[0])"], notes
        print(f"duplicated labels with a map: import {seconds:.2f} s wall, {cpu:.2f} s CPU "
              f"({size / 1e6 / seconds:.0f} MB/s; target <= 5 s)")


if __name__ == "__main__":
    main(*map(int, sys.argv[1:3]))
