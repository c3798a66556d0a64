"""Event handling of the shared runtime on small models with known answers:
indicators that touch zero without crossing (a grazing or tangent root)
must not move the solver off the true trajectory."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from loomfmu import build_fmu
from loomfmu.declare.model import Model

pytestmark = pytest.mark.slow  # builds FMUs


def _touch_model(root: float) -> Model:
    m = Model("touch", stop_time=2.0, step_size=0.25)
    x = m.state("x", 0.0, unit="m", description="position, moving at 1 m/s")
    m.eq(m.der(x), 1.0)
    m.event("touch", (m.t - root) ** 2, description="touches zero at t = root, never crosses")
    m.event("cross", x - 1.5, description="crosses zero at t = 1.5")
    m.output("x_out", x, unit="m", description="position")
    return m


@pytest.fixture(scope="module", params=[1.0, 0.6])
def touch_fmu(request, tmp_path_factory):
    root = request.param
    return root, build_fmu(_touch_model(root), out_dir=tmp_path_factory.mktemp("touch"),
                           validate=False).path


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
def test_touching_indicator_keeps_the_trajectory(touch_fmu, slave_factory, solver):
    """(t - root)^2 reaches 0 at a communication point (root 1.0: the step
    end sees e = 0, which counts as a sign change) or inside a step (0.6).
    The runtime may look for the root, but the redone trajectory keeps the
    indicator's sign: no event (or one exactly at the root), and x stays
    equal to t (an unbounded gap once
    carried the solver to t = 564 with x = 142 and doStep returned OK)."""
    root, path = touch_fmu
    s = slave_factory(path)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver, solver_h_fixed=1e-3)
    t = 0.0
    for i in range(8):
        s.fmu.doStep(t, 0.25)
        t = (i + 1) * 0.25
        assert s.get("x_out")[0] == pytest.approx(t, abs=1e-9), (t, s.log[-3:])
    events = [m for _, _, m in s.log if "event" in m]
    at = {name: [float(m.split()[2].rstrip(":")) for m in events if f"event {name}," in m]
          for name in ("touch", "cross")}
    assert len(at["cross"]) == 1 and at["cross"][0] == pytest.approx(1.5, abs=1e-9)
    # reaching 0 at a step end counts as reaching the other side: at most one
    # event, exactly at the root
    assert len(at["touch"]) <= 1 and all(abs(t - root) < 1e-9 for t in at["touch"])


def _dip_model() -> Model:
    m = Model("dip", stop_time=3.0, step_size=3.0)
    x = m.state("x", 1.0, unit="m", description="constant: the solver's error estimate is 0")
    m.eq(m.der(x), 0.0)
    # below zero only on 0.1 s around t = 0.5, 1.5, 2.5
    m.event("dip", np.cos(0.1 * np.pi) - ca.cos(2 * np.pi * (m.t - 0.5)),
            description="leaves its sign and comes back within 0.1 s, once a second")
    m.output("x_out", x, unit="m", description="x")
    return m


@pytest.mark.parametrize("solver", [1, 2])
@pytest.mark.parametrize("comm", [3.0, 0.5, 0.01])
def test_indicator_dips_inside_one_long_step_are_found(slave_factory, tmp_path_factory, solver,
                                                      comm):
    """The states are constant, so the solver's steps grow tenfold per step;
    the indicator, driven by time alone, is negative for 0.1 s once a
    second.  Every dip (two roots) is found whatever the communication step:
    6 events over 3 s (before the fix one fmi2DoStep over 3 s saw none)."""
    path = build_fmu(_dip_model(), out_dir=tmp_path_factory.mktemp("dip"), validate=False).path
    s = slave_factory(path)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver)
    for i in range(int(round(3.0 / comm))):
        s.fmu.doStep(i * comm, comm)
    at = [float(m.split()[2].rstrip(":")) for _, _, m in s.log if "event dip," in m]
    expected = [k + 0.5 + d for k in range(3) for d in (-0.05, 0.05)]
    assert len(at) == 6, at
    assert np.allclose(at, expected, atol=1e-9), at
