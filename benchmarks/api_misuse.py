"""Call the public Python API with bad arguments and count how each call ends.

    python benchmarks/api_misuse.py [--timeout S] [--verbose]

Every case is one call with one bad argument (NaN, +-inf, huge, negative,
zero, wrong type, unknown name, out-of-order range, a typo in a keyword, a
contradicting option) and the name the error message must contain.  Each
call runs in a forked child with a time limit, so a hang or a crash is
counted instead of stopping the run.  Outcomes:

* refused: the expected exception (ValueError unless the case says
  otherwise) whose message names the argument;
* unnamed: that exception, but the message does not name the argument;
* wrong-exception: any other exception (MemoryError, OverflowError, a bare
  TypeError, FMPy's Exception, ...);
* accepted: the call returned (silent nonsense);
* hung: no return within the time limit;
* crashed: the child died without an answer.

The test tests/test_api_validation.py runs the same table and asserts
"refused" for every case.  Exit status 1 if any case is not refused.
"""
from __future__ import annotations

import argparse
import importlib
import math
import multiprocessing as mp
import re
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Callable

import numpy as np

NAN, INF = math.nan, math.inf
#: default time limit of one call (s); a refused call takes milliseconds
TIMEOUT = 60.0
OUTCOMES = ("refused", "unnamed", "wrong-exception", "accepted", "hung", "crashed")


@dataclass
class Case:
    label: str                       # the call, as text
    arg: str                         # the name the message must contain
    call: Callable[["Fixtures"], Any]
    exc: type = ValueError           # the exception a proper refusal raises


class Fixtures:
    """Objects the calls need, made once in the parent before any fork."""

    def __init__(self, tmp: Path):
        self.tmp = tmp

    @cached_property
    def model(self):
        from loomfmu import load_model
        return load_model("heald_frame_rigid")

    @cached_property
    def fmu(self) -> Path:
        from loomfmu import build_fmu
        return build_fmu(self.model, out_dir=self.tmp, validate=False).path

    @cached_property
    def ref(self):
        from loomfmu.verification.reference import reference
        return reference(self.model, t_end=0.01)

    @cached_property
    def p(self):
        from loomfmu.drive import DriveParams
        return DriveParams()

    @cached_property
    def rotor(self):
        from loomfmu.mechanics.rotor import Rotor
        r = Rotor(2e11, 7800.0)
        r.element(0.1, 0.01)
        return r

    @cached_property
    def mats(self):
        M = np.eye(2)
        return M, 0.1 * np.eye(2), np.array([[4.0, 0.0], [0.0, 9.0]])

    @cached_property
    def spindle(self):
        from loomfmu.spindle.study import Spindle
        return Spindle({})

    def small(self):
        """A fresh small model with a state x (for declaration calls)."""
        from loomfmu.declare.model import Model
        m = Model("small")
        m.state("x", 0.0, description="x")
        return m

    def prepare(self) -> None:
        for name in ("model", "fmu", "ref", "p", "rotor", "mats", "spindle"):
            getattr(self, name)


def _load(name, **kw):
    from loomfmu import load_model
    return load_model(name, **kw)


def _ref(fx, **kw):
    from loomfmu.verification.reference import reference
    return reference(fx.model, **kw)


def _sim(fx, **kw):
    from loomfmu.verification.verify import simulate
    kw.setdefault("fmu", fx.fmu)
    return simulate(kw.pop("fmu"), **kw)


def _hinge(*args, **kw):
    from loomfmu.heald import hinge_load_kinetostatic
    return hinge_load_kinetostatic(*args, **kw)


def _phases(**kw):
    from loomfmu.heald import hinge_load_phases
    base = dict(m_RR=4.6, m_heald=0.9, a_max=40.0)
    return hinge_load_phases(**{**base, **kw})


def _drive(fn: str, *args, **kw):
    import loomfmu.drive as dr
    return getattr(dr, fn)(*args, **kw)


def _claims(fn: str, *args, **kw):
    from loomfmu.heald import claims
    return getattr(claims, fn)(*args, **kw)


def _rotor(fn: str, *args, **kw):
    import loomfmu.mechanics.rotor as ro
    return getattr(ro, fn)(*args, **kw)


def _analysis(fn: str, *args, **kw):
    import loomfmu.spindle.analysis as ra
    return getattr(ra, fn)(*args, **kw)


def _model(**kw):
    from loomfmu.declare.model import Model
    return Model(kw.pop("name", "m"), **kw)


def _declare(fx, fn: str, *args, **kw):
    """``fn`` of a fresh small model; strings "x" / "2x" / "x,2x" / "x|x" in
    ``args`` stand for x, 2 x, the column [x; 2 x] and the row [x, x], "empty"
    for a 0x1 expression, "x+alien" / "x+other x" for x plus a symbol the
    model did not declare (named "alien" / also named "x")."""
    import casadi as ca
    m = fx.small()
    x = m.var("x").sym
    subst = {"x": x, "2x": 2 * x, "x,2x": ca.vertcat(x, 2 * x), "x|x": ca.horzcat(x, x),
             "empty": ca.SX(0, 1), "x+alien": x + ca.SX.sym("alien"),
             "x+other x": x + ca.SX.sym("x")}
    args = [subst.get(a, a) if isinstance(a, str) else a for a in args]
    return getattr(m, fn)(*args, **kw)


def _build(fx, model=None, **kw):
    from loomfmu import build_fmu
    return build_fmu(fx.model if model is None else model, **{"validate": False, **kw})


def _a_file(folder: Path) -> Path:
    path = folder / "a_file"
    path.write_text("not a folder")
    return path


def _joint(fx, **kw):
    from loomfmu.mechanics.friction import coulomb_joint
    m = fx.small()
    tq = m.algebraic("tq", description="friction torque")
    args = dict(speed=m.var("x").sym, torque=tq, normal=1.0, r_kinetic=0.1, r_static=0.2)
    args.update(kw)
    return coulomb_joint(m, "J", **args)


def cases() -> list[Case]:
    """The table of bad calls."""
    C: list[Case] = []

    def add(label, arg, call, exc=ValueError):
        C.append(Case(label, arg, call, exc))

    # -- load_model and the build options of every model ------------------------
    add("load_model('loom')", "name", lambda fx: _load("loom"))
    add("load_model(3)", "name", lambda fx: _load(3))
    for v in (100000, 0, 2.5, True, "40", NAN):
        add(f"load_model('drive', m={v!r})", "m", lambda fx, v=v: _load("drive", m=v))
    for v in (True, 0, 1000, "96", 2.5):
        add(f"load_model('drive', harmonics={v!r})", "harmonics",
            lambda fx, v=v: _load("drive", harmonics=v))
    add("load_model('drive', cam='compensate')", "cam", lambda fx: _load("drive", cam="compensate"))
    for v in (NAN, INF, -1.0, 0.0, "5"):
        add(f"load_model('drive', max_delay={v!r})", "max_delay",
            lambda fx, v=v: _load("drive", max_delay=v))
    add("load_model('drive', tau=1.0)", "tau", lambda fx: _load("drive", tau=1.0))
    add("load_model('backrest', friction='coulomb')", "friction",
        lambda fx: _load("backrest", friction="coulomb"))
    for v in (0.0, NAN, INF, -1e-3, "1e-3", 100.0):
        add(f"load_model('backrest', eps={v!r})", "eps", lambda fx, v=v: _load("backrest", eps=v))
    add("load_model('backrest', frictoin='events')", "frictoin",
        lambda fx: _load("backrest", frictoin="events"))
    add("load_model('backrest_regularized', friction='events')", "friction",
        lambda fx: _load("backrest_regularized", friction="events"))
    add("load_model('heald_frame', end_dwell='printd')", "end_dwell",
        lambda fx: _load("heald_frame", end_dwell="printd"))
    add("load_model('heald_frame', inertia=1)", "inertia",
        lambda fx: _load("heald_frame", inertia=1))
    add("load_model('heald_frame', h_B_law='varying')", "h_B_law",
        lambda fx: _load("heald_frame", h_B_law="varying"))
    add("load_model('heald_frame', preset='STB-999 Elitex')", "preset",
        lambda fx: _load("heald_frame", preset="STB-999 Elitex"))
    add("load_model('heald_frame', preset=180)", "preset",
        lambda fx: _load("heald_frame", preset=180))
    add("load_model('heald_frame_planar', inertia='printed')", "inertia",
        lambda fx: _load("heald_frame_planar", inertia="printed"))
    add("load_model('heald_frame_rigid', h_B_law='variable')", "h_B_law",
        lambda fx: _load("heald_frame_rigid", h_B_law="variable"))
    add("load_model('heald_frame_rigid', end_dwell=None)", "end_dwell",
        lambda fx: _load("heald_frame_rigid", end_dwell=None))
    add("load_model('spindle', beem='euler')", "beem", lambda fx: _load("spindle", beem="euler"))
    for key, v in (("n_cone", 10**6), ("n_low", 2.5), ("n_low", 0), ("n_turns", 1),
                   ("damper", "x"), ("beam", "y"), ("n_turns", True)):
        add(f"load_model('spindle', {key}={v!r})", key,
            lambda fx, key=key, v=v: _load("spindle", **{key: v}))
    for key, v in (("n_modes", 0), ("n_modes", 100), ("basis_rpm", NAN), ("basis_rpm", -1.0)):
        add(f"load_model('spindle_modal', {key}={v!r})", key,
            lambda fx, key=key, v=v: _load("spindle_modal", **{key: v}))

    # -- reference ------------------------------------------------------------------
    for v in (NAN, INF, -1.0, 0.0, "1", 1e300):
        add(f"reference(t_end={v!r})", "t_end", lambda fx, v=v: _ref(fx, t_end=v))
    for v in (INF, NAN, 0.0, -1.0, "1e-6", 1.0):
        add(f"reference(rtol={v!r})", "rtol", lambda fx, v=v: _ref(fx, rtol=v))
    for v in (0.0, -INF, NAN, "x"):
        add(f"reference(atol={v!r})", "atol", lambda fx, v=v: _ref(fx, atol=v))
    for v in ("Euler", "rk45", None):
        add(f"reference(method={v!r})", "method", lambda fx, v=v: _ref(fx, method=v))
    add("reference(t_eval=[0.5], t_end=0.01)", "t_eval",
        lambda fx: _ref(fx, t_eval=[0.5], t_end=0.01))
    for v in ([NAN], [-1.0], [[0.0, 0.01]], "abc", [0.02, 0.01], [], [True]):
        add(f"reference(t_eval={v!r}, t_end=0.05)", "t_eval",
            lambda fx, v=v: _ref(fx, t_eval=v, t_end=0.05))
    for vals, arg in (({"omgea": 60.0}, "omgea"), ({"N_rem": 1.0}, "N_rem"),
                      ({"k_z": NAN}, "k_z"), ({"k_z": "five"}, "k_z"), ({"k_z": 1e9}, "k_z"),
                      ([("k_z", 1.0)], "values"), ({"T_min": 0.9, "T_max": 0.5}, "T_min"),
                      ({"omega": INF}, "omega")):
        add(f"reference(values={vals!r})", arg, lambda fx, v=vals: _ref(fx, values=v))
    for steps, arg in (([(0.01, {"omgea": 50.0})], "omgea"), ([(NAN, {"omega": 50.0})],
                       "input_steps"), ([(0.01, {"omega": -5.0})], "omega"),
                       ("x", "input_steps"), ([(0.02, {"omega": 50.0}), (0.01, {"omega": 1.0})],
                                              "input_steps"), ([(1.0, {"omega": 5.0})],
                                                               "input_steps")):
        add(f"reference(input_steps={steps!r}, t_end=0.05)", arg,
            lambda fx, s=steps: _ref(fx, input_steps=s, t_end=0.05))
    add("reference('heald_frame')", "model",
        lambda fx: importlib.import_module("loomfmu.verification.reference").reference("heald_frame"))

    # -- simulate, compare, verify -----------------------------------------------------
    for v in ("euler", "DOPRI5", 1):
        add(f"simulate(solver={v!r})", "solver", lambda fx, v=v: _sim(fx, solver=v))
    for v in (INF, NAN, 0.0, "1e-6", -1.0):
        add(f"simulate(rtol={v!r})", "rtol", lambda fx, v=v: _sim(fx, rtol=v))
    for v in (-1.0, NAN):
        add(f"simulate(atol={v!r})", "atol", lambda fx, v=v: _sim(fx, atol=v))
    for v in (-1.0, NAN, INF, 0.0, "1", 1e300):
        add(f"simulate(stop_time={v!r})", "stop_time", lambda fx, v=v: _sim(fx, stop_time=v))
    for v in (0.0, -1.0, NAN, 10.0):
        add(f"simulate(output_interval={v!r})", "output_interval",
            lambda fx, v=v: _sim(fx, output_interval=v))
    for vals, arg in (({"omgea": 1.0}, "omgea"), ({"N_rem": 1.0}, "N_rem"),
                      ({"k_z": NAN}, "k_z"), ({"k_z": "a"}, "k_z"), ("k_z=1", "values")):
        add(f"simulate(values={vals!r})", arg, lambda fx, v=vals: _sim(fx, values=v))
    add("simulate(values={'T_min': 0.9, 'T_max': 0.5})  [the FMU refuses]", "T_min",
        lambda fx: _sim(fx, values={"T_min": 0.9, "T_max": 0.5}), RuntimeError)
    add("simulate(output=['N_remm'])", "N_remm", lambda fx: _sim(fx, output=["N_remm"]))
    add("simulate(output='N_rem')", "output", lambda fx: _sim(fx, output="N_rem"))
    add("simulate(output=['h', 'h'])", "output", lambda fx: _sim(fx, output=["h", "h"]))
    add("simulate('nope.fmu')", "fmu", lambda fx: _sim(fx, fmu="nope.fmu"))
    for v in (7, 0, "rk4", True, 2.0):  # the `solver` enumeration has items 1..3
        add(f"simulate(values={{'solver': {v!r}}})", "solver",
            lambda fx, v=v: _sim(fx, values={"solver": v}))
    add("simulate(values={'k_z': 1e9})  [outside the FMU's max]", "k_z",
        lambda fx: _sim(fx, values={"k_z": 1e9}))
    add("simulate(values={'solver_atol': 5.0})", "solver_atol",
        lambda fx: _sim(fx, values={"solver_atol": 5.0}))
    add("simulate(atol=5.0)  [outside solver_atol's range]", "atol",
        lambda fx: _sim(fx, atol=5.0))
    add("simulate(rtol=1e-20)  [below solver_rtol's min]", "rtol",
        lambda fx: _sim(fx, rtol=1e-20))
    add("simulate(3)", "fmu", lambda fx: _sim(fx, fmu=3))

    def _verify(fx, **kw):
        from loomfmu.verification.verify import verify
        return verify(fx.fmu, kw.pop("model", fx.model), **kw)

    def _compare(fx, run=None, names=("h",)):
        from loomfmu.verification.verify import compare
        return compare(fx.ref if run is None else run, fx.ref, list(names))

    add("verify(solvers=['euler'])", "solvers", lambda fx: _verify(fx, solvers=["euler"]))
    add("verify(solvers=[])", "solvers", lambda fx: _verify(fx, solvers=[]))
    add("verify(model='heald_frame_rigid')", "model",
        lambda fx: _verify(fx, model="heald_frame_rigid"))
    add("verify(ref_rtol=inf)", "ref_rtol", lambda fx: _verify(fx, ref_rtol=INF))
    add("compare(ref, ref, ['N_remm'])", "N_remm", lambda fx: _compare(fx, names=["N_remm"]))
    add("compare('run', ref, ['h'])", "run", lambda fx: _compare(fx, run="run"))

    # -- heald: hinge, presets, claims ------------------------------------------------
    add("hinge_load_kinetostatic(0.0, omgea=100)", "omgea",
        lambda fx: _hinge(0.0, omgea=100.0), TypeError)
    for kw, arg in ((dict(m_RR=-1.0), "m_RR"), (dict(T_min=0.9, T_max=0.5), "T_min"),
                    (dict(n_hinge=0.0), "n_hinge"), (dict(omega=INF), "omega"),
                    (dict(g="9.8"), "g"), (dict(k_z=0.0), "k_z"), (dict(h_m=NAN), "h_m")):
        add(f"hinge_load_kinetostatic(0.0, **{kw!r})", arg, lambda fx, kw=kw: _hinge(0.0, **kw))
    for v in (NAN, "abc", [0.0, INF]):
        add(f"hinge_load_kinetostatic({v!r})", "phi", lambda fx, v=v: _hinge(v))
    for kw, arg in ((dict(m_RR=-1.0), "m_RR"), (dict(a_max=NAN), "a_max"),
                    (dict(n_hinge="2"), "n_hinge"), (dict(form="full"), "form"),
                    (dict(margin=0.5), "margin"), (dict(friction=NAN), "friction"),
                    (dict(N_warp=5.0), "N_warp"), (dict(form="general", dN=-1.0), "dN"),
                    (dict(g=INF), "g")):
        add(f"hinge_load_phases(**{kw!r})", arg, lambda fx, kw=kw: _phases(**kw))

    def _hinge_mod(fn, *a, **kw):
        from loomfmu.heald import hinge
        return getattr(hinge, fn)(*a, **kw)

    def _presets(fn, *a, **kw):
        from loomfmu.mechanics import heald_presets as presets
        return getattr(presets, fn)(*a, **kw)
    add("phase_of([0], [0], 0.029, band=1.5)", "band",
        lambda fx: _hinge_mod("phase_of", [0.0], [0.0], 0.029, band=1.5))
    add("phase_of([0, 1], [0], 0.029)", "h_dot",
        lambda fx: _hinge_mod("phase_of", [0.0, 1.0], [0.0], 0.029))
    add("max_phases({})", "loads", lambda fx: _hinge_mod("max_phases", {}))
    add("max_phases({'bottom dwell': 1}, rel_tol=2)", "rel_tol",
        lambda fx: _hinge_mod("max_phases", {"bottom dwell": 1.0}, rel_tol=2.0))
    add("max_phases({'nowhere': 1})", "nowhere", lambda fx: _hinge_mod("max_phases",
                                                                       {"nowhere": 1.0}))
    add("phase_extremes([1.0], [9])", "phase", lambda fx: _hinge_mod("phase_extremes", [1.0], [9]))
    add("preset_values('STB-180 Elitexx')", "preset",
        lambda fx: _presets("preset_values", "STB-180 Elitexx"))
    add("preset_values(None)", "preset", lambda fx: _presets("preset_values", None))
    add("warp_force(181, 'wool')", "width_cm", lambda fx: _presets("warp_force", 181, "wool"))
    add("warp_force(180, 'silk')", "yarn", lambda fx: _presets("warp_force", 180, "silk"))
    add("warp_force('180', 'wool')", "width_cm", lambda fx: _presets("warp_force", "180", "wool"))
    add("reduced_vertical_mass(-1)", "l", lambda fx: _presets("reduced_vertical_mass", -1.0))
    for v in (NAN, -1.0, "0.004", 0.0):
        add(f"design_section({v!r})", "gap", lambda fx, v=v: _claims("design_section", v))
    add("design_section(10)  [lower edge of the search]", "b1_range",
        lambda fx: _claims("design_section", 10.0))
    add("design_section(1e-6)  [upper edge of the search]", "b1_range",
        lambda fx: _claims("design_section", 1e-6))
    for v in ((0.1, 0.05), (0.0, 0.1), (0.005,), "wide", (0.005, NAN)):
        add(f"design_section(0.004, b1_range={v!r})", "b1_range",
            lambda fx, v=v: _claims("design_section", 0.004, b1_range=v))
    add("design_section(0.004, d1=0.01)", "d1", lambda fx: _claims("design_section", 0.004,
                                                                   d1=0.01))
    add("design_section(0.004, d1=-1)", "d1", lambda fx: _claims("design_section", 0.004, d1=-1.0))
    add("design_section(0.004, values={'b1': 0.01})", "b1",
        lambda fx: _claims("design_section", 0.004, values={"b1": 0.01}))
    add("design_section(0.004, values={'omgea': 1})", "omgea",
        lambda fx: _claims("design_section", 0.004, values={"omgea": 1.0}))
    add("claims.run('heald_frame_x')", "name", lambda fx: _claims("run", "heald_frame_x"))
    add("claims.run(cycles=0)", "cycles", lambda fx: _claims("run", cycles=0))
    add("claims.run(cycles=10**6)", "cycles", lambda fx: _claims("run", cycles=10**6))
    add("claims.run(values={'omega': 0})", "omega",
        lambda fx: _claims("run", values={"omega": 0.0}))
    add("claims.run(options={'inertia': 'x'})", "inertia",
        lambda fx: _claims("run", options={"inertia": "x"}))
    add("start_values('heald_frame_rigid')", "name",
        lambda fx: _claims("start_values", "heald_frame_rigid"))
    add("start_values(values={'nope': 1})", "nope",
        lambda fx: _claims("start_values", values={"nope": 1.0}))
    add("natural_frequencies(values={'E': -1})", "E",
        lambda fx: _claims("natural_frequencies", values={"E": -1.0}))
    add("fidelity({'spatial': 'x'})", "fmus", lambda fx: _claims("fidelity", {"spatial": "x"}))

    # -- drive: parameters, law, cam, tracking ----------------------------------------
    for kw, arg in ((dict(K=NAN), "K"), (dict(K=True), "K"), (dict(K="30"), "K"),
                    (dict(Kx=1.0), "Kx"), (dict(T_c=-1.0), "T_c"), (dict(n_max=0.1), "n_max"),
                    (dict(tau=INF), "tau"), (dict(T=0.0), "T"), (dict(K=1e-3), "K")):
        add(f"DriveParams(**{kw!r})", arg, lambda fx, kw=kw: _drive("DriveParams", **kw))
    add("DriveParams.from_rpm(n_min='12000')", "n_min",
        lambda fx: _drive("DriveParams").from_rpm(n_min="12000"))
    add("DriveParams.from_rpm(tauu=1)", "tauu", lambda fx: _drive("DriveParams").from_rpm(tauu=1))
    for v in (10**7, -1, 2.5, True, "40"):
        add(f"fourier(p, {v!r})", "m", lambda fx, v=v: _drive("fourier", fx.p, v))
    add("fourier(p, 10, panels=0)", "panels", lambda fx: _drive("fourier", fx.p, 10, panels=0))
    add("fourier(p, 1000, panels=10**6)", "panels",
        lambda fx: _drive("fourier", fx.p, 1000, panels=10**6))
    add("fourier('p', 10)", "p", lambda fx: _drive("fourier", "p", 10))
    for v in ([NAN], "abc", INF):
        add(f"speed_law({v!r}, p)", "t", lambda fx, v=v: _drive("speed_law", v, fx.p))
    add("speed_law(1.0, 'p')", "p", lambda fx: _drive("speed_law", 1.0, "p"))
    add("revolutions(inf, p)", "t", lambda fx: _drive("revolutions", INF, fx.p))
    add("speed_slope([nan], p)", "t", lambda fx: _drive("speed_slope", [NAN], fx.p))
    add("series(0, 1, [1, 2], [1], omega=1)", "b",
        lambda fx: _drive("series", 0.0, 1.0, [1.0, 2.0], [1.0], omega=1.0))
    add("series(0, nan, [1], [1], omega=1)", "C0",
        lambda fx: _drive("series", 0.0, NAN, [1.0], [1.0], omega=1.0))
    add("trig_eval(0, 0, [1], [1], omega=inf)", "omega",
        lambda fx: _drive("trig_eval", 0.0, 0.0, [1.0], [1.0], omega=INF))
    add("amplitude_phase([1, 2], [1])", "b", lambda fx: _drive("amplitude_phase", [1, 2], [1]))
    for kw, arg in ((dict(n_phi=7), "n_phi"), (dict(n_phi=10**9), "n_phi"),
                    (dict(M=5000), "M"), (dict(tol=0.0), "tol"), (dict(compensate="yes"),
                                                                  "compensate"),
                    (dict(sigma=1), "sigma")):
        add(f"cam_profile_phi(p, 10, **{kw!r})", arg,
            lambda fx, kw=kw: _drive("cam_profile_phi", fx.p, 10,
                                     **{"compensate": True, **kw}))
    add("cam_coefficients(p, 10**6, compensate=True)", "m",
        lambda fx: _drive("cam_coefficients", fx.p, 10**6, compensate=True))
    add("cam_radius(0, (1.0, [1.0], []), p)", "cam",
        lambda fx: _drive("cam_radius", 0.0, (1.0, [1.0], []), fx.p))
    add("cam_angle(0, p, coeffs=(1, 2))", "coeffs",
        lambda fx: _drive("cam_angle", 0.0, fx.p, coeffs=(1, 2)))
    add("time_of_angle(nan, p)", "phi", lambda fx: _drive("time_of_angle", NAN, fx.p))
    add("inverse_gain(p, -1)", "m", lambda fx: _drive("inverse_gain", fx.p, -1))
    add("fmu_cam_parameters(p, 10, tol=-1)", "tol",
        lambda fx: _drive("fmu_cam_parameters", fx.p, 10, tol=-1.0))
    t = np.linspace(0.0, 100.0, 1001)
    add("tracking_error(t, n, p, t_transient=-1)", "t_transient",
        lambda fx: _drive("tracking_error", t, 0 * t + 200.0, fx.p, t_transient=-1.0))
    add("tracking_error([0, 1], [1], p)", "n", lambda fx: _drive("tracking_error", [0.0, 1.0],
                                                                  [1.0], fx.p))
    add("tracking_error([1, 0], [1, 1], p)", "t",
        lambda fx: _drive("tracking_error", [1.0, 0.0], [1.0, 1.0], fx.p))
    add("tracking_error(t, n, p, m=10**7)", "m",
        lambda fx: _drive("tracking_error", t, 0 * t + 200.0, fx.p, 10**7))

    def _tracking(fn, *a, **kw):
        from loomfmu.drive import tracking
        return getattr(tracking, fn)(*a, **kw)

    def _report(fn, *a, **kw):
        from loomfmu.drive import report
        return getattr(report, fn)(*a, **kw)
    add("cam_values(p, 40, True, 0)", "harmonics",
        lambda fx: _tracking("cam_values", fx.p, 40, True, 0))
    add("cam_values(p, 40, 'yes', 96)", "compensate",
        lambda fx: _tracking("cam_values", fx.p, 40, "yes", 96))
    add("tracking_rows(taus=[nan])", "taus", lambda fx: _tracking("tracking_rows", taus=[NAN]))
    add("tracking_rows(rtol=inf)", "rtol", lambda fx: _tracking("tracking_rows", rtol=INF))
    add("tracking_rows(m=0)", "m", lambda fx: _tracking("tracking_rows", m=0))
    add("truncation_errors(p, [0])", "ms", lambda fx: _report("truncation_errors", fx.p, [0]))

    # -- rotor ----------------------------------------------------------------------------
    add("circle_section(-1)", "d_out", lambda fx: _rotor("circle_section", -1.0))
    add("circle_section(0.01, 0.02)", "d_in", lambda fx: _rotor("circle_section", 0.01, 0.02))
    add("circle_section('a')", "d_out", lambda fx: _rotor("circle_section", "a"))
    add("beam_planar(0, 1, 1, 1)", "l", lambda fx: _rotor("beam_planar", 0.0, 1.0, 1.0, 1.0))
    add("beam_planar(1, nan, 1, 1)", "EI", lambda fx: _rotor("beam_planar", 1.0, NAN, 1.0, 1.0))
    add("Rotor(-1, 7800)", "E", lambda fx: _rotor("Rotor", -1.0, 7800.0))
    add("Rotor(2e11, 7800, timoshenko='yes')", "timoshenko",
        lambda fx: _rotor("Rotor", 2e11, 7800.0, timoshenko="yes"))
    add("rotor.element(-1, 0.01)", "l", lambda fx: fx.rotor.element(-1.0, 0.01))
    add("rotor.disk(5, 1, 1, 1)", "node", lambda fx: fx.rotor.disk(5, 1.0, 1.0, 1.0))
    add("rotor.disk(0, -1, 0, 0)", "m", lambda fx: fx.rotor.disk(0, -1.0, 0.0, 0.0))
    add("rotor.spring(0, [[1, 2]], ...)", "K",
        lambda fx: fx.rotor.spring(0, [[1.0, 2.0]], [[0, 0], [0, 0]]))
    add("rotor.dof('n9.x')", "name", lambda fx: fx.rotor.dof("n9.x"))
    for v in (1, 10**9, "4"):
        add(f"spring_radii(0.01, 0.001, {v!r})", "n",
            lambda fx, v=v: _rotor("spring_radii", 0.01, 0.001, v))
    add("spring_radii(-1, 0.001, 4)", "r1", lambda fx: _rotor("spring_radii", -1.0, 0.001, 4))
    add("gauss_integral(sin, 0, 1, n=10**8)", "n",
        lambda fx: _rotor("gauss_integral", math.sin, 0.0, 1.0, n=10**8))
    add("gauss_integral(sin, 0, nan)", "b", lambda fx: _rotor("gauss_integral", math.sin, 0.0, NAN))
    add("gauss_integral('sin', 0, 1)", "fun", lambda fx: _rotor("gauss_integral", "sin", 0.0, 1.0))
    I2 = [[1.0, 0.0], [0.0, 1.0]]
    add("equivalent_support(I, I, I, I, 1, w=0)", "w",
        lambda fx: _rotor("equivalent_support", I2, I2, I2, I2, 1.0, 0.0))
    add("film_damping(1, [1, 2], 1, 1, 0, form='x')", "form",
        lambda fx: _rotor("film_damping", 1.0, [1.0, 2.0], 1.0, 1.0, 0.0, form="x"))
    add("isotropic(-1)", "k", lambda fx: _rotor("isotropic", -1.0))
    add("isotropic(1, nan)", "k_cross", lambda fx: _rotor("isotropic", 1.0, NAN))
    add("coil_spring_stiffness(2e11, 1e-3, 0.01, [0.01])", "radii",
        lambda fx: _rotor("coil_spring_stiffness", 2e11, 1e-3, 0.01, [0.01]))

    def _numeric(values):
        import casadi as ca
        x = ca.SX.sym("x")
        return _rotor("numeric", [x], x, values)
    add("numeric([x], x, [1, 2])", "values", lambda fx: _numeric([1.0, 2.0]))
    add("undamped_frequencies(I, ones(2, 3))", "K",
        lambda fx: _analysis("undamped_frequencies", np.eye(2), np.ones((2, 3))))
    add("complex_modes(M with nan, C, K)", "M",
        lambda fx: _analysis("complex_modes", np.full((2, 2), NAN), *fx.mats[1:]))
    add("campbell(f, [nan], [0], [1])", "speeds_rpm",
        lambda fx: _analysis("campbell", lambda w: (*fx.mats[:2], 0 * fx.mats[0], fx.mats[2]),
                             [NAN], [0], [1]))
    add("campbell(f, [0], [0], [1], n_modes=0)", "n_modes",
        lambda fx: _analysis("campbell", lambda w: (*fx.mats[:2], 0 * fx.mats[0], fx.mats[2]),
                             [0.0], [0], [1], n_modes=0))
    add("unbalance_response(M, C, K, nan, P1, P2)", "w",
        lambda fx: _analysis("unbalance_response", *fx.mats, NAN, [1.0, 0.0], [0.0, 1.0]))
    add("unbalance_response(M, C, K, 1, [1], P2)", "P1",
        lambda fx: _analysis("unbalance_response", *fx.mats, 1.0, [1.0], [0.0, 1.0]))
    add("dynamic_compliance(M, C, K, 1, a=[1])", "a",
        lambda fx: _analysis("dynamic_compliance", *fx.mats, 1.0, [1.0]))
    add("whirl_modes(M, C, K, [0], [5])", "y_idx",
        lambda fx: _analysis("whirl_modes", *fx.mats, [0], [5]))

    def _study(fn, *a, **kw):
        import loomfmu.spindle.study as rs
        return getattr(rs, fn)(*a, **kw)

    def _trends(fn, *a, **kw):
        import loomfmu.spindle.trends as rt
        return getattr(rt, fn)(*a, **kw)
    add("Spindle({'beem': 'x'})", "beem", lambda fx: _study("Spindle", {"beem": "x"}))
    add("spindle.values(fill=2)", "fill", lambda fx: fx.spindle.values(fill=2.0))
    add("spindle.values(nope=1)", "nope", lambda fx: fx.spindle.values(nope=1.0))
    add("spindle.unbalance(nan)", "speed_rpm", lambda fx: fx.spindle.unbalance(NAN))
    add("spindle.forward_freqs_rpm(n=0)", "n", lambda fx: fx.spindle.forward_freqs_rpm(n=0))
    add("spindle.matrices(inf)", "Omega", lambda fx: fx.spindle.matrices(INF))
    add("amplitude_table(spindle, fill=-1)", "fill",
        lambda fx: _study("amplitude_table", fx.spindle, -1.0))
    add("direction([0, 1])", "y", lambda fx: _trends("direction", [0.0, 1.0]))
    add("run_study('nope', 1e-6)", "name", lambda fx: _trends("run_study", "nope", 1e-6))
    add("run_study('lower_support', -1)", "ecc",
        lambda fx: _trends("run_study", "lower_support", -1.0))

    # -- declaration layer: Model, friction, symbolic, units ---------------------------
    add("Model('bad name')", "name", lambda fx: _model(name="bad name"))
    add("Model('m', stop_time=nan)", "stop_time", lambda fx: _model(stop_time=NAN))
    add("Model('m', step_size=2)", "step_size", lambda fx: _model(step_size=2.0))
    add("Model('m', h_fixed=-1)", "h_fixed", lambda fx: _model(h_fixed=-1.0))
    add("Model('m', reference_method='Euler')", "reference_method",
        lambda fx: _model(reference_method="Euler"))
    add("m.parameter('k', nan)", "k",
        lambda fx: fx.small().parameter("k", NAN, description="d", source="s"))
    add("m.parameter('k', 'one')", "k",
        lambda fx: fx.small().parameter("k", "one", description="d", source="s"))
    add("m.parameter('k', 1, min=2, max=1)", "min",
        lambda fx: fx.small().parameter("k", 1.0, description="d", source="s", min=2.0,
                                        max=1.0))
    add("m.state('y', 0, nominal=-1)", "nominal",
        lambda fx: fx.small().state("y", 0.0, description="d", nominal=-1.0))
    add("m.mode('q', 0, (0, True))", "values",
        lambda fx: fx.small().mode("q", 0, (0, True), description="d"))
    add("m.delay('d', x, 1.0, max_delay=nan)", "max_delay",
        lambda fx: (lambda m: m.delay("d", m.var("x").sym, 1.0, max_delay=NAN,
                                      description="d"))(fx.small()))
    add("m.var('nope')", "nope", lambda fx: fx.small().var("nope"))
    # non-scalar expressions: a vector output overran the FMU's buffers (SIGSEGV)
    for expr, text in (("x,2x", "[x; 2x]"), ("x|x", "[x, x]"), ("empty", "SX(0, 1)"),
                       (NAN, "nan"), (None, "None"), ("fast", "'fast'")):
        add(f"m.output('y', {text})", "y",
            lambda fx, e=expr: _declare(fx, "output", "y", e, description="y"))
    for expr in ("x+alien", "x+other x"):  # free variables of the generated code
        add(f"m.output('y', {expr})", "y",
            lambda fx, e=expr: _declare(fx, "output", "y", e, description="y"))
    add("m.delay('d', [x; 2x], 0.1)", "d",
        lambda fx: _declare(fx, "delay", "d", "x,2x", 0.1, max_delay=1.0, description="d"))
    add("m.delay('d', x, tau=[x; 2x])", "tau",
        lambda fx: _declare(fx, "delay", "d", "x", "x,2x", max_delay=1.0, description="d"))
    add("m.event('e', [x; 2x])", "e", lambda fx: _declare(fx, "event", "e", "x,2x"))
    add("m.constraint('c', [x, x], 'm')", "c",
        lambda fx: _declare(fx, "constraint", "c", "x|x", "m"))
    add("m.eq([x, x])", "lhs", lambda fx: _declare(fx, "eq", "x|x"))
    add("m.eq([x; 2x], zeros(3))", "rhs",
        lambda fx: _declare(fx, "eq", "x,2x", np.zeros(3)))
    add("m.reinit(2 x, 0)", "state", lambda fx: _declare(fx, "reinit", "2x", 0.0))
    add("m.der(2 x)", "x", lambda fx: _declare(fx, "der", "2x"))
    # texts XML or C cannot hold, reserved and duplicate names
    add("m.state('y', 0, description='a\\x00b')", "description",
        lambda fx: _declare(fx, "state", "y", 0.0, description="a\x00b"))
    add("m.parameter('k', 1, source='\\x1b[31m')", "source",
        lambda fx: _declare(fx, "parameter", "k", 1.0, description="k", source="\x1b[31m"))
    add("Model('m', description='\\x00')", "description",
        lambda fx: _model(description="\x00"))
    add("m.constraint('c', 1, 'two\\nlines')", "message",
        lambda fx: _declare(fx, "constraint", "c", 1.0, "two\nlines"))
    for name in ("solver_rtol", "solver", "solver_max_steps", "delay_interpolation", "time"):
        add(f"m.state({name!r}, 0)  [a name every FMU has]", name,
            lambda fx, n=name: _declare(fx, "state", n, 0.0, description="d"))
    add("m.state('x', 0)  [declared twice]", "x",
        lambda fx: fx.small().state("x", 0.0, description="d"))
    add("m.event('e', x) twice", "e",
        lambda fx: (lambda m: [m.event("e", m.var("x").sym) for _ in range(2)])(fx.small()))
    add("m.event('a b', x)", "name", lambda fx: _declare(fx, "event", "a b", "x"))
    add("m.port('p', 'flange', speed=3)", "speed",
        lambda fx: _declare(fx, "port", "p", "flange", speed=3))
    # build_fmu
    add("build_fmu(out_dir=<an existing file>)", "out_dir",
        lambda fx: _build(fx, out_dir=_a_file(fx.tmp)))
    add("build_fmu(out_dir=3)", "out_dir", lambda fx: _build(fx, out_dir=3))
    add("build_fmu('heald_frame_rigid')", "model", lambda fx: _build(fx, "heald_frame_rigid"))
    add("build_fmu(validate='yes')", "validate",
        lambda fx: _build(fx, out_dir=fx.tmp, validate="yes"))
    add("build_fmu(fmi_version=4)", "fmi_version",
        lambda fx: _build(fx, out_dir=fx.tmp, fmi_version=4))
    add("build_fmu(interface='hil')", "interface",
        lambda fx: _build(fx, out_dir=fx.tmp, interface="hil"))
    add("build_fmu(platforms='win32')", "platforms",
        lambda fx: _build(fx, out_dir=fx.tmp, platforms="win32"))
    add("build_fmu(platforms=[])", "platforms", lambda fx: _build(fx, out_dir=fx.tmp, platforms=[]))
    add("build_fmu(platforms='aarch64')", "platforms",
        lambda fx: _build(fx, out_dir=fx.tmp, platforms="aarch64"))

    def _unit(u):
        from loomfmu.declare.units import check_unit
        return check_unit(u)
    add("check_unit('furlong')", "unit", lambda fx: _unit("furlong"))
    add("check_unit(3)", "unit", lambda fx: _unit(3))
    add("coulomb_joint(r_kinetic=-1)", "r_kinetic", lambda fx: _joint(fx, r_kinetic=-1.0))
    add("coulomb_joint(r_static < r_kinetic)", "r_static",
        lambda fx: _joint(fx, r_kinetic=0.3, r_static=0.1))
    add("coulomb_joint(start=2)", "start", lambda fx: _joint(fx, start=2))
    add("coulomb_joint(regularized_eps=0)", "regularized_eps",
        lambda fx: _joint(fx, regularized_eps=0.0))
    add("coulomb_joint(speed='w')", "speed", lambda fx: _joint(fx, speed="w"))

    def _symbolic(fn, *a):
        import casadi as ca

        from loomfmu.mechanics import lagrange as symbolic
        q, qd = ca.SX.sym("q", 2), ca.SX.sym("qd", 2)
        subst = {"q": q, "qd": qd, "qdd": ca.SX.sym("qdd", 3), "T": ca.dot(qd, qd),
                 "V": ca.SX(0), "Q": ca.SX.zeros(2)}
        return getattr(symbolic, fn)(*[subst.get(x, x) if isinstance(x, str) else x
                                       for x in a])
    add("generalized_forces('P', qdot)", "power",
        lambda fx: _symbolic("generalized_forces", 1.0, "qd"))
    add("lagrange_equations(T, V, q, qd, qdd of 3, Q)", "qddot",
        lambda fx: _symbolic("lagrange_equations", "T", "V", "q", "qd", "qdd", "Q"))

    # -- sweep: where the results go (checked before the FMU is built) ---------------
    def _sweep_out(out):
        from loomfmu.sweep import Figure, Study, run_study
        study = Study("heald_frame_rigid", cases=[{"omega": 60.0}],
                      figures=[Figure("max", "N_rem")], stop_time=0.1, output_interval=0.01)
        return run_study(study, out=out)
    add("run_study(study, out='.')", "out", lambda fx: _sweep_out("."))
    add("run_study(study, out=<a file>/x.csv)", "out",
        lambda fx: _sweep_out(__file__ + "/x.csv"))
    return C


# ---------------------------------------------------------------------------- runner
def _names(message: str, arg: str) -> bool:
    return re.search(rf"(?<![A-Za-z0-9_]){re.escape(arg)}(?![A-Za-z0-9_])", message) is not None


def _child(case: Case, fx: Fixtures, conn) -> None:
    try:
        case.call(fx)
        conn.send(("returned", "", ""))
    except BaseException as e:  # noqa: BLE001 (everything is a finding here)
        conn.send((type(e).__name__, str(e)[:500],
                   "".join(traceback.format_exception_only(type(e), e))[:500]))
    conn.close()


def run_case(case: Case, fx: Fixtures, timeout: float = TIMEOUT) -> tuple[str, str]:
    """(outcome, detail) of one case, run in a forked child."""
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(case, fx, child))
    proc.start()
    child.close()
    ready = parent.poll(timeout)
    if not ready:
        proc.kill()
        proc.join()
        return "hung", f"no return within {timeout:g} s"
    try:
        kind, message, _ = parent.recv()
    except EOFError:
        proc.join()
        return "crashed", f"exit code {proc.exitcode}"
    proc.join()
    if kind == "returned":
        return "accepted", "returned without error"
    if kind == case.exc.__name__:
        if _names(message, case.arg):
            return "refused", message
        return "unnamed", message
    return "wrong-exception", f"{kind}: {message}"


def run_all(timeout: float = TIMEOUT, verbose: bool = False) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        fx = Fixtures(Path(tmp))
        fx.prepare()
        table = cases()
        counts = dict.fromkeys(OUTCOMES, 0)
        bad = []
        wall = time.perf_counter()
        for case in table:
            outcome, detail = run_case(case, fx, timeout)
            counts[outcome] += 1
            if outcome != "refused":
                bad.append((case.label, outcome, detail))
            if verbose:
                print(f"{outcome:16s} {case.label}: {detail[:160]}")
        wall = time.perf_counter() - wall
    return {"tried": len(table), **counts, "wall_seconds": wall, "not_refused": bad}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--timeout", type=float, default=TIMEOUT,
                    help=f"time limit of one call, s (default {TIMEOUT:g})")
    ap.add_argument("--verbose", action="store_true", help="print every case")
    args = ap.parse_args(argv)
    res = run_all(args.timeout, args.verbose)
    print(f"tried {res['tried']}: " + ", ".join(f"{k} {res[k]}" for k in OUTCOMES)
          + f" ({res['wall_seconds']:.1f} s)")
    for label, outcome, detail in res["not_refused"]:
        print(f"  {outcome}: {label}: {detail[:200]}")
    return 0 if res["refused"] == res["tried"] else 1


if __name__ == "__main__":
    sys.exit(main())
