"""FmuSession on FMUs that are not pythonfmu FMI 2.0 co-simulation: an FMI 3.0
co-simulation container (fmpy's container FMU around a structbench FMU) and
an FMI 2.0 model-exchange oscillator compiled here from C."""
from __future__ import annotations

import shutil
import subprocess
import sysconfig
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.container_fmu.cli import create_container_fmu
from fmpy.container_fmu.config import Component, Configuration
from fmpy.model_description import CoSimulation, ModelDescription, ModelVariable

from structbench.harness.fmu_session import FmuSession
from structbench.models import load_model
from structbench.models.statespace import StateSpace


@pytest.fixture(scope="module")
def fmi3_container(fmus, tmp_path_factory) -> Path:
    """FMI 3.0 co-simulation FMU exposing F_7_w, u_7_w, a_7_w, m_3 of ch4-cantilever-case1."""
    inner = fmus["ch4-cantilever-case1"]
    md = read_model_description(str(inner))
    inner_vars = {v.name: v for v in md.modelVariables}
    component = Component(name="beam", filename=inner, modelDescription=md)

    def var(name, causality, variability="continuous", **kw):
        return ModelVariable(type="Float64", name=name, causality=causality, variability=variability, **kw)

    mapped = [var("F_7_w", "input", start="0.0"), var("u_7_w", "output", initial="calculated"),
              var("a_7_w", "output", initial="calculated"), var("m_3", "parameter", "tunable", start="1.17")]
    container = ModelDescription(fmiVersion="3.0", modelName="Container", instantiationToken="{structbench}",
                                 coSimulation=CoSimulation(fixedInternalStepSize=0.01),
                                 modelVariables=[var("time", "independent"), *mapped])
    config = Configuration(parallelDoStep=False, modelDescription=container, components=[component],
                           connections=[], variableMappings={v: [(component, inner_vars[v.name])] for v in mapped})
    work = tmp_path_factory.mktemp("container")
    path = work / "container3.fmu"
    (work / "unzipped").mkdir()
    create_container_fmu(config, work / "unzipped", path)
    return path


def test_fmi3_co_simulation(fmi3_container):
    model = load_model("ch4-cantilever-case1")
    heavier = model.with_values(np.where([p.label == "mass[3]" for p in model.parameters], 1.5, model.values))
    dt, n = 0.01, 300
    force = np.sin(np.arange(n) * dt)[:, None]
    with FmuSession(fmi3_container) as fmu:
        got = fmu.run(["F_7_w"], ["u_7_w", "a_7_w"], force, dt)
        fmu.reset()
        fmu.set_parameters({"m_3": 1.5})
        got_heavier = fmu.run(["F_7_w"], ["u_7_w", "a_7_w"], force, dt)
    # no invalid values here: fmpy 0.3.32's container FMU segfaults as soon as its
    # pythonfmu component logs a message (our FMUs log only errors)
    i = model.dof_index(7, "w")
    full = np.zeros((n, model.n_dof))
    full[:, i] = force[:, 0]
    for m, y in ((model, got), (heavier, got_heavier)):
        ref = m.state_space().simulate(full, dt)
        np.testing.assert_allclose(y[:, 0], ref["displacement"][:, i], rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(y[:, 1], ref["acceleration"][:, i], rtol=1e-9, atol=1e-12)


OSCILLATOR_C = r"""
#include <stdlib.h>
#include "fmi2Functions.h"
/* m x'' + c x' + k x = F; value references: 0 F, 1 u, 2 v, 3 a, 4 m, 5 c, 6 k */
typedef struct { fmi2Real r[7]; fmi2Real time; } Model;
static void accel(Model *s) { s->r[3] = (s->r[0] - s->r[5] * s->r[2] - s->r[6] * s->r[1]) / s->r[4]; }
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String x[]) { return fmi2OK; }
fmi2Component fmi2Instantiate(fmi2String n, fmi2Type t, fmi2String g, fmi2String r,
                              const fmi2CallbackFunctions *f, fmi2Boolean v, fmi2Boolean l) {
    Model *s = calloc(1, sizeof(Model)); s->r[4] = 2.0; s->r[5] = 0.3; s->r[6] = 50.0; return s; }
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean a, fmi2Real b, fmi2Real t0, fmi2Boolean d, fmi2Real e)
    { ((Model *)c)->time = t0; return fmi2OK; }
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
    { accel(c); for (size_t i = 0; i < n; i++) v[i] = ((Model *)c)->r[vr[i]]; return fmi2OK; }
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
    { for (size_t i = 0; i < n; i++) ((Model *)c)->r[vr[i]] = v[i]; return fmi2OK; }
fmi2Status fmi2EnterEventMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e)
    { e->newDiscreteStatesNeeded = e->terminateSimulation = e->nominalsOfContinuousStatesChanged =
      e->valuesOfContinuousStatesChanged = e->nextEventTimeDefined = fmi2False; return fmi2OK; }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean a, fmi2Boolean *e, fmi2Boolean *t)
    { *e = *t = fmi2False; return fmi2OK; }
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Model *)c)->time = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n)
    { ((Model *)c)->r[1] = x[0]; ((Model *)c)->r[2] = x[1]; return fmi2OK; }
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n)
    { x[0] = ((Model *)c)->r[1]; x[1] = ((Model *)c)->r[2]; return fmi2OK; }
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n)
    { accel(c); dx[0] = ((Model *)c)->r[2]; dx[1] = ((Model *)c)->r[3]; return fmi2OK; }
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n)
    { for (size_t i = 0; i < n; i++) x[i] = 1.0; return fmi2OK; }
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) { return fmi2OK; }
#define UNSUPPORTED(name, ...) fmi2Status name(__VA_ARGS__) { return fmi2Error; }
UNSUPPORTED(fmi2GetInteger, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
UNSUPPORTED(fmi2GetBoolean, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
UNSUPPORTED(fmi2GetString, fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
UNSUPPORTED(fmi2SetInteger, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
UNSUPPORTED(fmi2SetBoolean, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
UNSUPPORTED(fmi2SetString, fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
UNSUPPORTED(fmi2GetFMUstate, fmi2Component c, fmi2FMUstate *s)
UNSUPPORTED(fmi2SetFMUstate, fmi2Component c, fmi2FMUstate s)
UNSUPPORTED(fmi2FreeFMUstate, fmi2Component c, fmi2FMUstate *s)
UNSUPPORTED(fmi2SerializedFMUstateSize, fmi2Component c, fmi2FMUstate s, size_t *n)
UNSUPPORTED(fmi2SerializeFMUstate, fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
UNSUPPORTED(fmi2DeSerializeFMUstate, fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
UNSUPPORTED(fmi2GetDirectionalDerivative, fmi2Component c, const fmi2ValueReference u[], size_t nu,
            const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[])
"""

OSCILLATOR_XML = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Oscillator" guid="{oscillator}" numberOfEventIndicators="0">
  <ModelExchange modelIdentifier="oscillator"/>
  <ModelVariables>
    <ScalarVariable name="F" valueReference="0" causality="input" variability="continuous"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="1" causality="output" variability="continuous" initial="exact"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="v" valueReference="2" causality="output" variability="continuous" initial="exact"><Real start="0" derivative="2"/></ScalarVariable>
    <ScalarVariable name="a" valueReference="3" causality="output" variability="continuous" initial="calculated"><Real derivative="3"/></ScalarVariable>
    <ScalarVariable name="m" valueReference="4" causality="parameter" variability="fixed"><Real start="2"/></ScalarVariable>
    <ScalarVariable name="c" valueReference="5" causality="parameter" variability="fixed"><Real start="0.3"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="6" causality="parameter" variability="fixed"><Real start="50"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="2"/><Unknown index="3"/><Unknown index="4"/></Outputs>
    <Derivatives><Unknown index="3"/><Unknown index="4"/></Derivatives>
    <InitialUnknowns><Unknown index="4"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


@pytest.fixture(scope="module")
def me_oscillator(tmp_path_factory) -> Path:
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None or not sysconfig.get_platform().startswith("linux"):
        pytest.skip("needs a C compiler on Linux to build the model-exchange test FMU")
    work = tmp_path_factory.mktemp("oscillator")
    (work / "oscillator.c").write_text(OSCILLATOR_C)
    library = work / "oscillator.so"
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run([cc, "-shared", "-fPIC", "-O2", f"-I{headers}", "-o", str(library), str(work / "oscillator.c")],
                   check=True, capture_output=True)
    path = work / "oscillator.fmu"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("modelDescription.xml", OSCILLATOR_XML)
        zf.write(library, "binaries/linux64/oscillator.so")
    return path


def test_model_exchange(me_oscillator):
    mass, damping, stiffness = 2.5, 0.3, 50.0
    ss = StateSpace.second_order(np.array([[mass]]), np.array([[damping]]), np.array([[stiffness]]))
    dt, n = 0.01, 200
    force = np.where(np.arange(n) < 100, 1.0, -0.5)[:, None]
    with FmuSession(me_oscillator) as fmu:
        fmu.set_parameters({"m": mass})
        got = fmu.run(["F"], ["u", "v", "a"], force, dt)
        with pytest.raises(Exception, match="cannot continue a run"):
            fmu.run(["F"], ["u"], force, dt, start_time=n * dt)
        fmu.reset()
        again = fmu.run(["F"], ["u", "v", "a"], force, dt)
    ref = ss.simulate(force, dt)
    exact = np.column_stack([ref["displacement"], ref["velocity"], ref["acceleration"]])
    assert (np.abs(got - exact).max(axis=0) < 1e-6 * np.abs(exact).max(axis=0)).all()  # CVode tolerance
    np.testing.assert_array_equal(got, again)
