"""Import throughput: a UFF 58 binary file of 100 channels x 360,000 samples
(1 h at 100 Hz, 288 MB of doubles) into a trace folder.

The file is written first (structbench's UFF writer, accelerations in g on
nodes 1..100, +Z); only ``structbench.import_data`` is timed: reading and
checking the datasets, converting g to m/s^2 and writing the HDF5 trace
atomically. Prints the file size, the import time and the throughput.

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


def write_file(path: Path, channels: int, samples: int) -> None:
    rng = np.random.default_rng(0)
    time_axis = np.arange(samples) * 0.01
    records = [Record58(i + 1, (f"A{i + 1}", "NONE", "NONE", "NONE", "NONE"), 1, i + 1, 3, 1, 3,
                        Axis(17, (0, 0, 0), "Time", "s"), Axis(12, (0, 0, 0), "Acceleration", "g"),
                        time_axis, rng.standard_normal(samples), True)
               for i in range(channels)]
    write_uff58(path, records, binary=True)


def main(channels: int = 100, samples: int = 360_000) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        source = Path(tmp) / "hour.uff"
        write_file(source, channels, samples)
        size = source.stat().st_size
        start = time.perf_counter()
        written = sb.import_data([source], Path(tmp) / "lab")
        seconds = time.perf_counter() - start
        print(f"{channels} channels x {samples} samples, UFF 58 binary {size / 1e6:.0f} MB -> "
              f"{written[0].stat().st_size / 1e6:.0f} MB HDF5: import {seconds:.2f} s "
              f"({size / 1e6 / seconds:.0f} MB/s; target < 10 s)")


if __name__ == "__main__":
    main(*map(int, sys.argv[1:3]))
