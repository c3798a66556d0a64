"""An FMI 3 container (FMPy's container FMU, fmpy.container_fmu) runs the
two-mass scene built from our FMI 3 co-simulation FMUs (two_mass_force,
two_mass_displacement; loomfmu.machines.two_mass), and agrees with our own
master (loomfmu.scene, FMI 2 FMUs of the same declarations) at the same fixed
step, and with the exact co-simulation map of the benchmark.

The container exchanges the values of its connections in the order they are
listed, then steps every component: listing the displacement side's outputs
first gives our Jacobi master with the feedthrough resolved (the force is
computed with the positions at t); listing the force first passes on a force
computed with the previous step's positions, as our Jacobi master with
resolve_feedthrough=False (libcosim's exchange) does.  Either way the
master and the container do the same arithmetic: the states agree to
rounding.  The recorded force differs by what it is computed with: the
container reads it with the inputs of t (consistent with the positions at t),
our master right after the step, with the inputs held over the step.
"""
from __future__ import annotations

import uuid
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.container_fmu import Configuration
from fmpy.container_fmu.cli import create_container_fmu
from fmpy.container_fmu.config import Component, Connection
from fmpy.model_description import (
    CoSimulation,
    DefaultExperiment,
    ModelDescription,
    ModelVariable,
    Unknown,
)
from fmpy.validation import validate_fmu
from test_fmi_variants import variant_builds  # FMUs shared by the variant tests

from loomfmu.machines.two_mass import TIGHT, Params, cosim_map, scene
from loomfmu.scene import run

pytestmark = pytest.mark.slow  # builds FMUs

H = 1e-3      # the container's fixed step = our master's communication step
STOP = 0.2
X1_0 = 0.1
SIDES = {"force": "two_mass_force", "disp": "two_mass_displacement"}
#: (component, variable) the container shows as outputs
OUTPUTS = (("force", "x1_out"), ("force", "v1_out"), ("disp", "x2_out"), ("disp", "v2_out"),
           ("force", "F_c"))
#: the exchange orders and the master that orders the same
ORDERS = {"disp-first": {}, "force-first": {"resolve_feedthrough": False}}


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    d = tmp_path_factory.mktemp("container")
    # FMI 2 co-simulation only: the scene checks the FMUs' variables against
    # its components' (a "both" FMU adds der(x))
    keys = [(m, v, "cs") for v in (3, 2) for m in SIDES.values()]
    built = variant_builds(tmp_path_factory, keys)
    fmi3 = dict(zip(SIDES, built[:2]))
    fmi2 = {k: b.path for k, b in zip(SIDES, built[2:])}
    return d, fmi3, fmi2


def _container(d: Path, fmi3: dict, order: str) -> Path:
    """The container FMU of the two-mass scene: outputs OUTPUTS, parameters
    the scene's (x1 start, tight solver tolerances), connections in
    ``order``."""
    comps = {}
    for key, result in fmi3.items():
        comps[key] = Component(name=key, filename=Path(result.path),
                               modelDescription=read_model_description(str(result.path)))

    def var(key, name):
        return next(v for v in comps[key].modelDescription.modelVariables if v.name == name)

    to_force = [Connection(comps["disp"], [var("disp", f"{q}2_out")], comps["force"],
                           [var("force", f"{q}2_in")]) for q in ("x", "v")]
    to_disp = [Connection(comps["force"], [var("force", "F_c")], comps["disp"],
                          [var("disp", "F_in")])]
    md = ModelDescription(fmiVersion="3.0", modelName="two_mass_container",
                          instantiationToken=str(uuid.uuid4()))
    md.coSimulation = CoSimulation(modelIdentifier="container_fmu", fixedInternalStepSize=H)
    md.defaultExperiment = DefaultExperiment(startTime="0", stopTime=str(STOP),
                                             stepSize=str(H))
    # time first: the container's value reference 0 is time, its variables
    # (the configuration's list, in the order of the mappings) follow from 1
    md.modelVariables.append(ModelVariable(name="time", causality="independent",
                                           variability="continuous", type="Float64"))
    mappings = {}
    parameters = [("force", "x1", X1_0)] + [(k, n, v) for k in SIDES for n, v in TIGHT.items()]
    for key, name in OUTPUTS:
        v = ModelVariable(name=f"{key}.{name}", causality="output", variability="continuous",
                          type="Float64")
        md.modelVariables.append(v)
        mappings[v] = [(comps[key], var(key, name))]
    for key, name, value in parameters:
        v = ModelVariable(name=f"{key}.{name}", causality="parameter", variability="fixed",
                          type="Float64", initial="exact")
        v.start = repr(float(value))
        md.modelVariables.append(v)
        mappings[v] = [(comps[key], var(key, name))]
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    md.outputs = [Unknown(variable=v) for v in outputs]
    md.initialUnknowns = [Unknown(variable=v) for v in outputs]
    connections = to_force + to_disp if order == "disp-first" else to_disp + to_force
    config = Configuration(parallelDoStep=False, modelDescription=md,
                           components=list(comps.values()), connections=connections,
                           variableMappings=mappings)
    work = d / f"unzip_{order}"
    work.mkdir(exist_ok=True)
    out = d / f"two_mass_container_{order}.fmu"
    create_container_fmu(config, work, out)
    return out


@pytest.mark.parametrize("order", ORDERS)
def test_container_runs_the_two_mass_scene(builds, order):
    d, fmi3, fmi2 = builds
    for result in fmi3.values():
        assert result.problems == []
    container = _container(d, fmi3, order)
    assert list(validate_fmu(str(container))) == []
    log = []
    res = simulate_fmu(str(container), stop_time=STOP, output_interval=H,
                       logger=lambda *args: log.append(args[-1]))
    assert not [m for m in log if b"rror" in m], log[:5]
    assert len(res) == round(STOP / H) + 1

    # our master, ordered the same, on the FMI 2 FMUs of the same declarations
    ours = run(scene(x1_0=X1_0, stop_time=STOP, step=H), master="jacobi", step=H,
               extrapolation=0, fmus=fmi2, master_options=ORDERS[order])
    assert np.allclose(ours.data["time"], res["time"], rtol=0, atol=1e-12)
    p = Params.declared()
    x1, v1, x2, v2 = (res[f"{k}.{n}"] for k, n in OUTPUTS[:4])
    F_now = p.kc * (x1 - x2) + p.dc * (v1 - v2)
    F_held = p.kc * (x1[1:] - x2[:-1]) + p.dc * (v1[1:] - v2[:-1])
    # the force recorded: the container's is the coupling's at the positions at
    # t, ours (read right after the step) the one computed with the inputs held
    # over the step; each equals its formula to rounding
    F_scale = np.max(np.abs(F_now))
    assert np.max(np.abs(res["force.F_c"] - F_now)) < 1e-12 * F_scale
    assert np.max(np.abs(ours.data["force.F_c"][1:] - F_held)) < 1e-12 * F_scale
    for key, name in OUTPUTS[:4]:
        ref = ours.data[f"{key}.{name}"]
        scale = np.max(np.abs(ref))
        np.testing.assert_allclose(res[f"{key}.{name}"], ref, rtol=0, atol=1e-12 * scale,
                                   err_msg=f"{key}.{name}")

    # the exact co-simulation map of the exchange (the FMUs at rtol 1e-12)
    algorithm = "jacobi" if order == "disp-first" else "libcosim"
    M = cosim_map(Params.declared(), H, algorithm)
    z = np.zeros(len(M))
    z[0] = X1_0
    zs = [z]
    for _ in range(len(res) - 1):
        zs.append(M @ zs[-1])
    zs = np.array(zs)
    for j, (key, name) in enumerate(OUTPUTS[:4]):
        y = res[f"{key}.{name}"]
        assert np.max(np.abs(y - zs[:, j])) < 1e-10 * np.max(np.abs(zs[:, j])), name
