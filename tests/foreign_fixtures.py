"""Build the 1-DOF mass-spring-damper FMU of tests/foreign_fmu, an FMU that
structbench did not build (gcc, fmpy's FMI 2.0 headers): m = 1 kg,
k = 1e4 N/m, d = 10 N s/m (omega = 100 rad/s, zeta = 0.05), co-simulation by
explicit Euler at the communication step and/or model exchange; one force
input ``f`` (N), one output: ``y`` = x + 1 mm, or ``v`` (m/s)."""
from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import fmpy

SOURCE = Path(__file__).parent / "foreign_fmu"
HEADERS = Path(fmpy.__file__).parent / "c-code"
M, K, D, Y0 = 1.0, 1.0e4, 10.0, 1.0e-3 # kg, N/m, N s/m, m: the FMU's parameter start values
OMEGA = (K / M) ** 0.5                 # rad/s, undamped natural frequency (100)
ZETA = D / (2.0 * (K * M) ** 0.5)      # damping ratio (0.05)

XML = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Msd" guid="{{7b0e5a61-2f4c-4d7e-9a1b-msd{velocity:d}00000001}}"
    generationTool="gcc (tests/foreign_fmu)" numberOfEventIndicators="0">
  {interfaces}
  <UnitDefinitions><Unit name="N"><BaseUnit kg="1" m="1" s="-2"/></Unit></UnitDefinitions>
  <ModelVariables>
    <ScalarVariable name="f" valueReference="0" causality="input" variability="continuous"><Real unit="N" start="0"/></ScalarVariable>
    <ScalarVariable name="{output}" valueReference="1" causality="output" variability="continuous"><Real/></ScalarVariable>
    <ScalarVariable name="m" valueReference="2" causality="parameter" variability="fixed" initial="exact"><Real start="{m}"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="3" causality="parameter" variability="fixed" initial="exact"><Real start="{k}"/></ScalarVariable>
    <ScalarVariable name="d" valueReference="4" causality="parameter" variability="fixed" initial="exact"><Real start="{d}"/></ScalarVariable>
    <ScalarVariable name="y0" valueReference="5" causality="parameter" variability="fixed" initial="exact"><Real start="{y0}"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="6" causality="local" variability="continuous" initial="exact"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="7" causality="local" variability="continuous"><Real derivative="7"/></ScalarVariable>
    <ScalarVariable name="xd" valueReference="8" causality="local" variability="continuous" initial="exact"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="der(xd)" valueReference="9" causality="local" variability="continuous"><Real derivative="9"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="2"/></Outputs>
    <Derivatives><Unknown index="8"/><Unknown index="10"/></Derivatives>
    <InitialUnknowns><Unknown index="2"/><Unknown index="8"/><Unknown index="10"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""
ELEMENTS = {"co-simulation": '<CoSimulation modelIdentifier="Msd" canHandleVariableCommunicationStepSize="true"/>',
            "model-exchange": '<ModelExchange modelIdentifier="Msd"/>'}


def build_msd(folder: Path, velocity: bool = False,
              interfaces: tuple[str, ...] = ("co-simulation", "model-exchange")) -> Path:
    """``folder/Msd[V][-cs|-me].fmu``: output ``y`` (m, offset y0), or ``v``
    (m/s) with ``velocity``; offering ``interfaces``."""
    tag = ("V" if velocity else "") + ("" if len(interfaces) == 2 else "-" + interfaces[0][:2])
    library = folder / f"msd{tag}.so"
    command = ["gcc", "-shared", "-fPIC", "-O2", "-o", str(library), f"-I{HEADERS}", str(SOURCE / "msd.c"), "-lm"]
    subprocess.run(command + (["-DVELOCITY"] if velocity else []), check=True, capture_output=True)
    xml = XML.format(velocity=velocity, interfaces="\n  ".join(ELEMENTS[i] for i in interfaces),
                     output="v" if velocity else "y", m=M, k=K, d=D, y0=Y0)
    fmu = folder / f"Msd{tag}.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", xml)
        z.write(library, "binaries/linux64/Msd.so")
    return fmu


CAMPAIGN_HEAD = """\
name = "msd"
structure = "{fmu}"
seed = {seed}
interface = "model-exchange"
[mapping]
force = "f"
displacement = "y"

[locations]
1 = [0.0, 0.0, 0.0]

"""


def msd_campaign(folder: Path, fmu: Path, seed: int, tests: str) -> Path:
    """``folder/msd.toml``: the FMU ``fmu`` through model exchange, force
    ``f`` and position ``y`` at location 1, with the ``[[tests]]`` text ``tests``."""
    path = folder / "msd.toml"
    path.write_text(CAMPAIGN_HEAD.format(fmu=fmu, seed=seed) + tests)
    return path

