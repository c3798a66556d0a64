"""Exact directional derivatives (lf_dirder.c through fmi2GetDirectionalDerivative):
the Jacobian of the state derivatives and outputs with respect to the states
and inputs, column by column, against central finite differences of the
FMU's own fmi2GetDerivatives / fmi2GetReal (model exchange: states set with
fmi2SetContinuousStates); its nonzeros against the model structure's
dependencies; co-simulation gives the same Jacobian as model exchange at
the same point; bad arguments give fmi2Error with a log, never a crash.

Models: an explicit one with inputs (two_mass_force), an implicit one with
modes (backrest: Newton, the derivative through dF/dw), one with delays
(drive: zero and positive delays)."""
from __future__ import annotations

from ctypes import c_double, c_uint

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Model
from test_fmi_variants import variant_builds  # FMUs shared by the variant tests

pytestmark = pytest.mark.slow  # builds FMUs

MODELS = ("two_mass_force", "backrest", "drive")
#: central differences with h = 1e-6 (relative): truncation ~1e-12, Newton's
#: tolerance (1e-10) / h for the implicit model
FD_RTOL = {"two_mass_force": 1e-7, "backrest": 1e-4, "drive": 1e-7}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    built = variant_builds(tmp_path_factory, [(n, 2, "both") for n in MODELS])
    return {n: b.path for n, b in zip(MODELS, built)}


class MEInstance:
    """A model-exchange instance in continuous-time mode, its log captured."""

    def __init__(self, path):
        self.md = read_model_description(str(path))
        self.fmu = FMU2Model(guid=self.md.guid, unzipDirectory=extract(str(path)),
                             modelIdentifier=self.md.modelExchange.modelIdentifier,
                             instanceName="me")
        self.log: list[str] = []
        self.fmu.instantiate(loggingOn=False)
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.fmu.newDiscreteStates()
        self.fmu.enterContinuousTimeMode()
        mv = self.md.modelVariables
        self.ders = [v for v in mv if v.derivative is not None]
        self.states = [v.derivative for v in self.ders]
        self.outputs = [v for v in mv if v.causality == "output" and v.type == "Real"]
        self.inputs = [v for v in mv if v.causality == "input"]
        self.nx = len(self.states)

    def states_now(self) -> np.ndarray:
        buf = (c_double * self.nx)()
        self.fmu.fmi2GetContinuousStates(self.fmu.component, buf, self.nx)
        return np.array(buf)

    def unknowns(self) -> list[int]:
        return [v.valueReference for v in self.ders + self.outputs]

    def knowns(self) -> list[int]:
        return [v.valueReference for v in self.states + self.inputs]

    def values(self, x, u) -> np.ndarray:
        self.fmu.setContinuousStates((c_double * self.nx)(*x), self.nx)
        if self.inputs:
            self.fmu.setReal([v.valueReference for v in self.inputs], list(u))
        return np.array(self.fmu.getReal(self.unknowns()))

    def jacobian(self) -> np.ndarray:
        unk, kn = self.unknowns(), self.knowns()
        cols = []
        for j in range(len(kn)):
            seed = [0.0] * len(kn)
            seed[j] = 1.0
            cols.append(self.fmu.getDirectionalDerivative(unk, kn, seed))
        return np.array(cols).T

    def differences(self, x, u) -> np.ndarray:
        cols = []
        for j in range(self.nx + len(u)):
            xp, xm, up, um = x.copy(), x.copy(), u.copy(), u.copy()
            v = x[j] if j < self.nx else u[j - self.nx]
            h = 1e-6 * max(1.0, abs(v))
            if j < self.nx:
                xp[j] += h
                xm[j] -= h
            else:
                up[j - self.nx] += h
                um[j - self.nx] -= h
            cols.append((self.values(xp, up) - self.values(xm, um)) / (2 * h))
        self.values(x, u)
        return np.array(cols).T


def _point(inst: MEInstance, seed: int):
    """A point off the start: states moved, inputs moved, t > 0."""
    rng = np.random.default_rng(seed)
    x = inst.states_now() * (1 + 0.02 * rng.standard_normal(inst.nx)) + \
        0.01 * rng.standard_normal(inst.nx)
    u = np.array([float(v.start or 0.0) for v in inst.inputs]) + 0.1
    inst.fmu.setTime(0.013)
    return x, u


@pytest.mark.parametrize("name", MODELS)
def test_jacobian_equals_central_differences(fmus, name):
    inst = MEInstance(fmus[name])
    try:
        x, u = _point(inst, 17)
        inst.values(x, u)
        J = inst.jacobian()
        F = inst.differences(x, u)
    finally:
        inst.fmu.terminate()
        inst.fmu.freeInstance()
    assert np.count_nonzero(J) > 0
    scale = np.maximum(np.abs(F).max(axis=1, keepdims=True), 1e-12)
    worst = np.abs(J - F) / scale
    assert worst.max() <= FD_RTOL[name], np.unravel_index(worst.argmax(), worst.shape)


@pytest.mark.parametrize("name", MODELS)
def test_nonzeros_are_listed_in_the_model_structure(fmus, name):
    """Every nonzero d(unknown)/d(known) is a declared dependency (fmi_structure):
    the derivatives' and the outputs' on states and inputs."""
    inst = MEInstance(fmus[name])
    try:
        x, u = _point(inst, 5)
        inst.values(x, u)
        J = inst.jacobian()
    finally:
        inst.fmu.terminate()
        inst.fmu.freeInstance()
    deps = {}
    for unknown in inst.md.derivatives + inst.md.outputs:
        deps[unknown.variable.valueReference] = (
            None if unknown.dependencies is None
            else {d.valueReference for d in unknown.dependencies})
    for i, vr in enumerate(inst.unknowns()):
        if deps.get(vr) is None:
            continue  # depends on everything known
        for j, kvr in enumerate(inst.knowns()):
            if J[i, j] != 0.0:
                assert kvr in deps[vr], (vr, kvr, J[i, j])


def test_co_simulation_gives_the_model_exchange_jacobian(fmus, slave_factory):
    """After co-simulation steps, the Jacobian at the instance's (t, x, u)
    equals model exchange's at the same point."""
    s = slave_factory(fmus["two_mass_force"])
    s.start()
    for k in range(4):
        s.fmu.doStep(0.01 * k, 0.01)
    inst = MEInstance(fmus["two_mass_force"])
    try:
        x = np.array(s.fmu.getReal([v.valueReference for v in inst.states]))
        u = np.array(s.fmu.getReal([v.valueReference for v in inst.inputs]))
        inst.fmu.setTime(0.04)
        inst.values(x, u)
        J_me = inst.jacobian()
        unk, kn = inst.unknowns(), inst.knowns()
        J_cs = np.array([s.fmu.getDirectionalDerivative(unk, kn, list(np.eye(len(kn))[j]))
                         for j in range(len(kn))]).T
    finally:
        inst.fmu.terminate()
        inst.fmu.freeInstance()
    np.testing.assert_allclose(J_cs, J_me, rtol=1e-13, atol=0)
    assert np.count_nonzero(J_cs) > 0


@pytest.mark.parametrize("case, message", [
    ("parameter_known", "allowed: states and inputs"),
    ("state_unknown", "allowed: outputs and algebraic locals"),
    ("beyond", "not a Real of the model"),
    ("nan_seed", "allowed: a finite number"),
    ("too_many", "nothing read"),
])
def test_bad_arguments_are_refused_with_a_log(fmus, slave_factory, case, message):
    s = slave_factory(fmus["two_mass_force"])
    s.start()
    md = s.md
    state = next(v for v in md.modelVariables if v.causality == "local"
                 and v.variability == "continuous" and v.derivative is None
                 and any(d.derivative is v for d in md.modelVariables))
    out = next(v for v in md.modelVariables if v.causality == "output")
    par = next(v for v in md.modelVariables if v.causality == "parameter"
               and v.variability == "fixed" and v.type == "Real")
    unknown, known, seed = [out.valueReference], [state.valueReference], [1.0]
    if case == "parameter_known":
        known = [par.valueReference]
    elif case == "state_unknown":
        unknown = [state.valueReference]
    elif case == "beyond":
        known = [10 ** 6]
    elif case == "nan_seed":
        seed = [float("nan")]
    if case == "too_many":  # a count far beyond the arrays: refused before reading them
        with pytest.raises(FMICallException):
            s.fmu.fmi2GetDirectionalDerivative(
                s.fmu.component, (c_uint * 1)(*unknown), 10 ** 9, (c_uint * 1)(*known), 1,
                (c_double * 1)(*seed), (c_double * 1)())
    else:
        with pytest.raises(FMICallException):
            s.fmu.getDirectionalDerivative(unknown, known, seed)
    assert any(message in m for _, _, m in s.log), s.log[-3:]
