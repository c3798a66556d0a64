"""FMI calls at the edges of what a model description declares: value
references it does not declare, illegal instantiation arguments, and the
words of a refusal after a discarded step."""
from __future__ import annotations

from ctypes import byref

import pytest
from conftest import Slave
from fmpy import extract, read_model_description
from fmpy.fmi3 import (
    FMU3Slave,
    fmi3Boolean,
    fmi3Float64,
    fmi3InstanceEnvironment,
    fmi3IntermediateUpdateCallback,
    fmi3LogMessageCallback,
)

from loomfmu import build_fmu, load_model

pytestmark = pytest.mark.slow  # builds FMUs


@pytest.fixture(scope="module")
def cs_fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("fmi_calls")
    model = load_model("two_mass_force")
    return {v: build_fmu(model, out_dir=out / f"fmi{v}", fmi_version=v).path for v in (2, 3)}


def test_fmi2_cs_build_refuses_the_value_references_of_der_x(cs_fmus):
    """A co-simulation-only FMI 2.0 build declares no der(x): their value
    references (nReal ... nReal + nx - 1 in a model-exchange build) are
    unknown there, and fmi2GetReal says so instead of returning OK."""
    md = read_model_description(str(cs_fmus[2]))
    declared = {v.valueReference for v in md.modelVariables if v.type == "Real"}
    assert not any(v.name.startswith("der(") for v in md.modelVariables)
    s = Slave(cs_fmus[2], "edges")
    s.start()
    first_undeclared = max(declared) + 1
    with pytest.raises(Exception):  # noqa: B017 (FMPy raises a bare Exception on Error)
        s.fmu.getReal([first_undeclared])
    assert any(str(first_undeclared) in m for _, _, m in s.log), s.log[-3:]
    assert s.fmu.getReal([max(declared)])  # a declared one still reads


def _instantiate_raw(path, n_required):
    md = read_model_description(str(path))
    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(path)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="raw")
    log = []
    cb = fmi3LogMessageCallback(lambda env, status, cat, msg: log.append(msg.decode()))
    inst = f.fmi3InstantiateCoSimulation(
        b"raw", md.instantiationToken.encode(), None, fmi3Boolean(False), fmi3Boolean(True),
        fmi3Boolean(False), fmi3Boolean(False), None, n_required, fmi3InstanceEnvironment(),
        cb, fmi3IntermediateUpdateCallback())
    return f, inst, log


def test_fmi3_null_required_intermediate_variables_with_a_count_is_refused(cs_fmus):
    f, inst, log = _instantiate_raw(cs_fmus[3], 3)
    assert not inst, "instantiated with requiredIntermediateVariables = NULL and a count of 3"
    assert any("requiredIntermediateVariables is NULL" in m and "= 3" in m for m in log), log
    f, inst, log = _instantiate_raw(cs_fmus[3], 0)   # NULL and 0: a legal empty list
    assert inst
    f.fmi3FreeInstance(inst)


def test_fmi3_refusal_after_a_discarded_step_says_so(cs_fmus):
    """After fmi3DoStep returned Discard, a second fmi3DoStep is refused with
    words that say why (both states are FMI 3.0's StepMode)."""
    md = read_model_description(str(cs_fmus[3]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(cs_fmus[3])),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="discard")
    log = []
    f.instantiate(loggingOn=True, logMessage=lambda env, st, cat, msg: log.append(msg.decode()))
    f.setFloat64([vr["solver_max_steps"]], [1.0])   # one solver step per call: a discard
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    flags = [fmi3Boolean() for _ in range(3)]
    last = fmi3Float64()
    status = f.dll.fmi3DoStep(f.component, fmi3Float64(0.0), fmi3Float64(1.0), fmi3Boolean(True), byref(flags[0]),
                              byref(flags[1]), byref(flags[2]), byref(last))
    assert status == 2, (status, log[-3:])   # fmi3Discard
    status = f.dll.fmi3DoStep(f.component, fmi3Float64(last.value), fmi3Float64(0.1),
                              fmi3Boolean(True), byref(flags[0]), byref(flags[1]),
                              byref(flags[2]), byref(last))
    assert status == 3, status   # fmi3Error
    said = log[-1]
    assert "after fmi3DoStep returned fmi3Discard" in said and "fmi3Terminate" in said, said
    assert "allowed in: StepMode" not in said
