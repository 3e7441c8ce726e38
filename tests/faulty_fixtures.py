"""Build the misbehaving C FMU of tests/faulty_fmu (gcc, fmpy's FMI 2.0 headers)."""
from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import fmpy

SOURCE = Path(__file__).parent / "faulty_fmu"
HEADERS = Path(fmpy.__file__).parent / "c-code"
FAIL_KINDS = {"error": 1, "fatal": 2, "segfault": 3, "hang": 4, "nan": 5}


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
