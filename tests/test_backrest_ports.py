"""The backrest's build options and ports: built-in shedding off,
two front ports (the ends of heald frames A and B), inputs that mean what the
warp port kind says (elongation from the static state, positive stretches;
tension absolute), defaults that agree with the heald frame's, and the
validity conditions (a slack warp ends the step with fmi2Discard and a log
line naming the condition and the time)."""
from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest

from loomfmu import build_fmu, load_model
from loomfmu.declare.ports import port_kind
from loomfmu.verification.reference import reference


def _params(model):
    return {v.name: v.start for v in model.of_kind("parameter")}


def test_shedding_off_removes_its_parameters_and_time_dependence():
    for name, opts in (("backrest", {}), ("backrest_regularized", {"friction": "regularized"})):
        on, off = load_model(name, **opts), load_model(name, shedding=False, **opts)
        assert {"A_shed", "omega_loom"} <= set(_params(on))
        assert not {"A_shed", "omega_loom"} & set(_params(off))
        assert set(_params(on)) - set(_params(off)) == {"A_shed", "omega_loom"}
        assert off.options["shedding"] is False
        for m, depends in ((on, True), (off, False)):
            S2 = m.var("S2").expr
            assert ca.depends_on(S2, m.t) == depends


@pytest.mark.parametrize("option, value", [("shedding", 1), ("shedding", "no"),
                                           ("shedding", None), ("fronts", 3),
                                           ("fronts", 2.0), ("fronts", True),
                                           ("fronts", 0)])
def test_bad_build_options_name_the_option(option, value):
    with pytest.raises(ValueError, match=rf"{option} = .*allowed"):
        load_model("backrest", **{option: value})


@pytest.mark.parametrize("fronts", [1, 2])
def test_ports_follow_the_warp_kind(fronts):
    m = load_model("backrest", shedding=False, fronts=fronts)
    kind = port_kind("warp")
    ports = {p.name: p for p in m.ports}
    fronts_expected = ({"warp_front": ("warp_pull", "S2")} if fronts == 1 else
                       {"warp_front_a": ("warp_pull_a", "S2a"),
                        "warp_front_b": ("warp_pull_b", "S2b")})
    expected = {**fronts_expected, "warp_back": ("letoff", "S1")}
    assert set(ports) == set(expected)
    for name, (elong, tension) in expected.items():
        p = ports[name]
        assert p.kind == "warp"
        assert p.variables == {"elongation": elong, "tension": tension}
        e, t = m.var(elong), m.var(tension)
        assert (e.kind, e.unit, t.kind, t.unit) == ("input", kind.roles["elongation"].unit,
                                                    "output", kind.roles["tension"].unit)
        assert "static state" in e.description and "positive stretches" in e.description
        assert "absolute" in t.description


@pytest.mark.parametrize("fronts", [1, 2])
def test_positive_elongation_stretches(fronts):
    """At rest (rates zero), dS/d(elongation input) is the branch's stiffness,
    positive; a half-sheet's input loads only its own half."""
    m = load_model("backrest", shedding=False, fronts=fronts)
    p = _params(m)
    psyms = ca.vertcat(*[v.sym for v in m.of_kind("parameter")])
    pvals = ca.DM([v.start for v in m.of_kind("parameter")])
    rates = ca.vertcat(m.var("omega1").sym, m.var("omega2").sym)

    def slope(out, inp):
        d = ca.jacobian(m.var(out).expr, m.var(inp).sym)
        d = ca.substitute(ca.substitute(d, rates, ca.DM.zeros(2)), psyms, pvals)
        return float(ca.evalf(d))
    assert slope("S1", "letoff") == pytest.approx(p["c1"])
    if fronts == 1:
        assert slope("S2", "warp_pull") == pytest.approx(p["c2"])
    else:
        assert slope("S2a", "warp_pull_a") == pytest.approx(p["c2"] / 2)
        assert slope("S2b", "warp_pull_b") == pytest.approx(p["c2"] / 2)
        assert slope("S2a", "warp_pull_b") == 0.0
        assert slope("S2", "warp_pull_a") == pytest.approx(p["c2"] / 2)


def test_validity_conditions_are_the_tensions():
    for fronts, names in ((1, {"warp_back_taut": "S1", "warp_front_taut": "S2"}),
                          (2, {"warp_back_taut": "S1", "warp_front_a_taut": "S2a",
                               "warp_front_b_taut": "S2b"})):
        m = load_model("backrest", shedding=False, fronts=fronts)
        got = {c.name: c for c in m.validity}
        assert set(got) == set(names)
        for cname, out in names.items():
            assert ca.is_equal(ca.simplify(got[cname].expr - m.var(out).expr), ca.SX(0))
            assert "warp in compression" in got[cname].message
            assert "not valid for a slack warp" in got[cname].message


def test_defaults_agree_with_the_heald_frame():
    """Static tension = 2 frames x n_n x T_min (the heald frame's tension at
    the closed shed, the port's static state); the upper branch's stiffness
    gives the heald frame's tension span n_n (T_max - T_min) per frame over
    its shed elongation dl_max, and the built-in shedding is that dl_max."""
    from loomfmu.models.heald_common import warp_geometry
    b, h = _params(load_model("backrest")), _params(load_model("heald_frame_rigid"))
    dl_max = float(warp_geometry(h["h_m"], h["l_1"], h["k_z"] * h["l_1"])[0])
    assert b["S0"] == pytest.approx(2 * h["n_n"] * h["T_min"])
    assert b["A_shed"] == pytest.approx(dl_max, rel=1e-4)
    assert b["c2"] * dl_max == pytest.approx(2 * h["n_n"] * (h["T_max"] - h["T_min"]),
                                             rel=5e-3)
    mean = b["S0"] + b["c2"] * b["A_shed"] / 2     # a rigid backrest, over one pick
    assert mean == pytest.approx(2 * h["n_n"] * (h["T_min"] + h["T_max"]) / 2, rel=5e-3)


# -- FMUs ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("backrest_ports")
    return {fronts: build_fmu(load_model("backrest", shedding=False, fronts=fronts),
                              out_dir=out / f"fronts{fronts}").path for fronts in (1, 2)}


def _run(path, comm, t_end, schedule, names, solver=1):
    """Step an FMU, setting inputs from ``schedule`` [(t, {input: value})] at
    the communication points; outputs after every step, the mode switches,
    the log and the status of the last step."""
    from conftest import Slave
    from fmpy.fmi1 import FMICallException
    s = Slave(path)
    s.fmu.setDebugLogging(True, ["logEvents", "logStatusDiscard", "logStatusError"])
    s.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12)
    ys, status = [], "ok"
    for i in range(int(round(t_end / comm))):
        t = i * comm
        for ts, values in schedule:
            if abs(ts - t) < 1e-9:
                s.set(**values)
        try:
            s.fmu.doStep(t, comm)
        except FMICallException as exc:
            status = str(exc)
            break
        ys.append(s.get(*names))
    log = [msg for _, _, msg in s.log]
    s.fmu.terminate()
    s.fmu.freeInstance()
    return np.array(ys), log, status


def _switches(log):
    """(time, mode, new value) of each mode switch in an FMU log."""
    out = []
    for msg in log:
        hit = re.match(r"t = (\S+): mode (\S+): \S+ -> (\S+)", msg)
        if hit:
            out.append((float(hit.group(1)), hit.group(2), int(hit.group(3))))
    return out


def _shed_schedule(comm, t_end, amplitude, picks_per_s=4.0, phase=0.0):
    """A heald-frame-like elongation, (1 - cos)/2 per pick, held over each step."""
    ts = np.arange(0, t_end, comm)
    return [(t, amplitude * (1 - math.cos(2 * math.pi * picks_per_s * t + phase)) / 2)
            for t in ts]


@pytest.mark.slow
def test_two_equal_halves_are_the_whole_sheet(fmus):
    """Both frames' ends stretched alike: the two-front backrest moves as the
    one-front backrest under the same elongation (S2a + S2b = S2)."""
    comm, t_end = 0.01, 0.5
    shed = _shed_schedule(comm, t_end, 0.009)
    names1 = ["phi1_out", "omega2_out", "S2", "S1"]
    y1, log1, st1 = _run(fmus[1], comm, t_end, [(t, {"warp_pull": v}) for t, v in shed],
                         names1)
    y2, log2, st2 = _run(fmus[2], comm, t_end, [(t, {"warp_pull_a": v, "warp_pull_b": v})
                                                 for t, v in shed],
                         names1 + ["S2a", "S2b"])
    assert st1 == st2 == "ok"
    sw1, sw2 = _switches(log1), _switches(log2)
    assert len(sw1) >= 4                         # the scene sticks and slips
    assert [s[1:] for s in sw1] == [s[1:] for s in sw2]
    assert max(abs(a[0] - b[0]) for a, b in zip(sw1, sw2)) < 1e-9
    for j, name in enumerate(names1):
        span = np.ptp(y1[:, j]) + 1e-3
        assert np.abs(y1[:, j] - y2[:, j]).max() < 1e-8 * span, name
    np.testing.assert_allclose(y2[:, 4] + y2[:, 5], y2[:, 2], rtol=1e-12)
    np.testing.assert_allclose(y2[:, 4], y2[:, 5], rtol=1e-12)


@pytest.mark.parametrize("solver", [1, 2])
@pytest.mark.slow
def test_two_fronts_against_the_reference(fmus, solver):
    """Frames A and B in opposition stretch their own ends at different times:
    the FMU against the scipy reference with the same input steps."""
    comm, t_end = 0.01, 0.4
    a = _shed_schedule(comm, t_end, 0.009)
    b = _shed_schedule(comm, t_end, 0.006, phase=math.pi / 2)
    sched = [(t, {"warp_pull_a": va, "warp_pull_b": vb}) for (t, va), (_, vb) in zip(a, b)]
    names = ["phi1_out", "omega1_out", "omega2_out", "S2a", "S2b", "S1"]
    ys, log, status = _run(fmus[2], comm, t_end, sched, names, solver=solver)
    assert status == "ok"
    m = load_model("backrest", shedding=False, fronts=2)
    # outputs just before each communication point: the FMU's S2a, S2b (fed
    # through from the inputs) still see the inputs of the step that ends there
    t_eval = np.concatenate([[0.0], np.arange(1, len(ys) + 1) * comm - 1e-10])
    ref = reference(m, t_end=t_end, t_eval=t_eval, rtol=1e-11, atol=1e-13,
                    values=sched[0][1], input_steps=sched[1:])
    # the FMU chooses its modes again at t = 0, where the inputs are first set;
    # the reference starts with them set
    sw = [x for x in _switches(log) if x[0] > 0]
    assert [x[1:] for x in sw] == [(n, q) for _, n, _, q in ref.switches] and sw
    assert max(abs(a[0] - b[0]) for a, b in zip(sw, ref.switches)) < 1e-6
    assert np.ptp(ys[:, 3] - ys[:, 4]) > 100.0     # the halves carry different tensions
    for j, name in enumerate(names):
        span = np.ptp(ref.y[name]) + 1e-3
        assert np.abs(ys[:, j] - ref.y[name][1:]).max() < 1e-6 * span, name


@pytest.mark.parametrize("fronts, inp, cond, text", [
    (1, "warp_pull", "warp_front_taut", "(upper branch)"),
    (2, "warp_pull_a", "warp_front_a_taut", "(upper branch, frame A's ends)"),
    (1, "letoff", "warp_back_taut", "(lower branch)")])
@pytest.mark.slow
def test_slack_warp_is_discarded_with_a_log_line(fmus, fronts, inp, cond, text):
    """An elongation input that releases the branch past its static tension
    (tension < 0) ends the step with fmi2Discard; the log names the
    condition, the message and the time."""
    m = load_model("backrest", shedding=False, fronts=fronts)
    p = _params(m)
    stiff = p["c1"] if inp == "letoff" else p["c2"] / fronts
    release = -1.5 * (p["S0"] / fronts if inp != "letoff" else p["S0"]) / stiff
    ys, log, status = _run(fmus[fronts], 0.01, 0.3, [(0.1, {inp: release})],
                           ["S1", "S2"])
    assert "discard" in status.lower()
    assert len(ys) == 10                          # the steps before 0.1 s were fine
    assert np.all(np.isfinite(ys)) and np.all(ys > 0)
    hits = [x for x in log if x.startswith(cond)]
    assert hits, log[-3:]
    assert f"warp in compression {text}" in hits[0]
    assert "t = 0.1" in hits[0] or "t = 0.09999" in hits[0]


@pytest.mark.slow
def test_a_small_release_stays_valid(fmus):
    """The same input at a third of the static tension keeps the warp taut:
    the condition does not fire on a valid state."""
    p = _params(load_model("backrest", shedding=False))
    ys, log, status = _run(fmus[1], 0.01, 0.3, [(0.1, {"warp_pull": -p["S0"] / p["c2"] / 3})],
                           ["S2"])
    assert status == "ok" and len(ys) == 30 and ys.min() > 0
