"""Build the misbehaving C FMU of tests/faulty_fmu (gcc, fmpy's FMI 2.0 headers)."""
from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import fmpy

SOURCE = Path(__file__).parent / "faulty_fmu"
HEADERS = Path(fmpy.__file__).parent / "c-code"
FAIL_KINDS = {"error": 1, "fatal": 2, "segfault": 3, "hang": 4, "nan": 5}

# A campaign on Faulty.fmu (format with kind, fmu and the fail_kind code): the
# test "faulty" reaches fail_force and misbehaves at step 10, "calm" and
# "noisy" (three repetitions) never do; every task has a 4 s time limit.
CAMPAIGN = """\
name = "faulty-{kind}"
structure = "{fmu}"

[parameters]
fail_kind = {code}
fail_step = 10
fail_force = 100.0

[mapping]
force = "F_{{node}}_{{dir}}"
displacement = "u_{{node}}_{{dir}}"
acceleration = "a_{{node}}_{{dir}}"

[locations]
1 = [0.0, 0.0, 0.0]

[defaults]
dt = 0.01
duration = 1.0
timeout = 4
sensors = [{{nodes = "all", dirs = ["z"], quantities = ["displacement", "acceleration"]}}]

[[tests]]
name = "calm"
excitation = [{{kind = "harmonic", node = 1, dir = "z", amplitude = 1.0, omega = 5.0}}]

[[tests]]
name = "faulty"   # 500 N >= fail_force: the fault strikes at step 10
excitation = [{{kind = "harmonic", node = 1, dir = "z", amplitude = 500.0, omega = 0.0}}]

[[tests]]
name = "noisy"
repetitions = 3
noise = {{sensor = 0.01}}
excitation = [{{kind = "random", node = 1, dir = "z", rms = 1.0, band = [1.0, 30.0]}}]
"""
CALM = ["calm.h5", "noisy.r000.h5", "noisy.r001.h5", "noisy.r002.h5"]


def build_faulty(folder: Path, refuse: bool = False) -> Path:
    """``folder/Faulty.fmu`` (``Refusing.fmu`` with ``refuse``: it cannot be instantiated)."""
    name = "Refusing" if refuse else "Faulty"
    library = folder / f"{name}.so"
    command = ["gcc", "-shared", "-fPIC", "-O1", "-o", str(library), f"-I{HEADERS}", str(SOURCE / "faulty.c"), "-lm"]
    subprocess.run(command + (["-DREFUSE"] if refuse else []), check=True, capture_output=True)
    fmu = folder / f"{name}.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.write(SOURCE / "modelDescription.xml", "modelDescription.xml")
        z.write(library, "binaries/linux64/Faulty.so")
    return fmu
