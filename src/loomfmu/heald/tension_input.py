"""The heald frame with the warp tension as an input (build option
``warp_tension="input"``): the figures of docs/guides/heald_tension_input.md.

* :func:`lockstep`: the geometry-tension FMU and the input-tension FMU run
  side by side, the input FMU's tension set at each communication point to
  the geometry FMU's (held over the step); how far the slats then differ
  tells what holding the tension costs a co-simulation;
* :func:`defaults`: the numbers the backrest's defaults take from the heald
  frame (ends, tension per end at the closed and the open shed, the time
  mean over a frame cycle, the stiffness the seed's tension law implies);
* :func:`opposition`: the second frame of a plain weave is the same FMU
  started one revolution later (phi = 2 pi), and phi = pi is not it.

    loomfmu heald tension-input        # docs/guides/heald_tension_input.md
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from loomfmu.declare.checks import check_number

SLATS = ("x2_out", "y2_out", "N_rem")


class _Instance:
    def __init__(self, path: Path, name: str):
        md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                             modelIdentifier=md.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate()

    def get(self, *names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def set(self, **values):
        self.fmu.setReal([self.vr[n] for n in values], [float(v) for v in values.values()])

    def start(self, **values):
        self.fmu.setupExperiment(startTime=0.0)
        self.set(**values)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def lockstep(geometry_fmu, input_fmu, dt: float, t_end: float, names, make=None):
    """Run both FMUs from t = 0 to ``t_end`` at communication step ``dt``;
    before each step the input FMU's T is set to the geometry FMU's T.
    Returns the records of ``names`` (rows: communication points) of the
    geometry and the input FMU.  make(path, name): an instance with
    get/set/start/fmu (default: FMPy's FMU2Slave)."""
    dt = check_number("dt", dt, lo=0.0, lo_open=True, unit="s")
    t_end = check_number("t_end", t_end, lo=dt, unit="s")
    own = make is None
    make = make or _Instance
    g, i = make(geometry_fmu, "geometry"), make(input_fmu, "input")
    try:
        g.start()
        i.start(T=g.get("T")[0])   # the input FMU starts at the same static deflection
        rec_g, rec_i = [g.get(*names)], [i.get(*names)]
        for k in range(int(round(t_end / dt))):
            i.set(T=g.get("T")[0])
            g.fmu.doStep(k * dt, dt)   # FMPy raises on a status other than OK
            i.fmu.doStep(k * dt, dt)
            rec_g.append(g.get(*names))
            rec_i.append(i.get(*names))
    finally:
        if own:
            g.close()
            i.close()
    return np.array(rec_g), np.array(rec_i)


def lockstep_errors(geometry_fmu, input_fmu, steps=(1e-3, 1e-4, 1e-5)):
    """{dt: {output: max |difference| / range of the geometry FMU's output}}
    over one frame cycle (two revolutions at the default 60 rad/s)."""
    t_end = 4 * math.pi / 60
    out = {}
    for dt in steps:
        rg, ri = lockstep(geometry_fmu, input_fmu, dt, t_end, SLATS)
        out[dt] = {n: float(np.max(np.abs(rg[:, k] - ri[:, k])) / np.ptp(rg[:, k]))
                   for k, n in enumerate(SLATS)}
    return out


def defaults(n: int = 20001) -> dict[str, float]:
    """The heald frame's default warp figures (seed 000), from its model:
    tension per end at the closed shed (dl = 0) and the open shed, the time
    mean over a frame cycle at constant speed, dl_max, and the stiffness
    n_n (T_max - T_min)/dl_max of the frame's ends the tension law implies."""
    import casadi as ca

    from loomfmu.registry import load_model
    m = load_model("heald_frame_rigid")
    p = {v.name: v.start for v in m.of_kind("parameter")}
    known = [v for v in m.variables if v.kind in ("parameter", "state", "input")]
    f = ca.Function("f", [ca.vertcat(*[v.sym for v in known])],
                    [m.var("T").expr, m.var("dl").expr])
    T, dl = [], []
    for phi in np.linspace(0.0, 4 * math.pi, n):
        t_, d_ = f(ca.DM([phi if v.name == "phi" else v.start for v in known]))
        T.append(float(t_))
        dl.append(float(d_))
    T, dl = np.array(T), np.array(dl)
    nn = p["n_n"]
    return {"n_n": nn, "T_min": p["T_min"], "T_max": p["T_max"],
            "T_end_mean": float(np.mean((T[:-1] + T[1:]) / 2) / nn),
            "dl_max": float(dl.max()),
            "k_ends": nn * (p["T_max"] - p["T_min"]) / float(dl.max()),
            "omega": m.var("omega").start, "omega_rpm": m.var("omega").start * 30 / math.pi}


def opposition(rigid_input_fmu) -> dict[str, float]:
    """max |h_A + h_B| with frame B started at phi = 2 pi, max |dl_A - dl_B|,
    and h at the start for phi = pi (half-way up, not in opposition)."""
    from loomfmu.verification.verify import simulate
    a = simulate(rigid_input_fmu, rtol=1e-9, output=["h", "dl"])
    b = simulate(rigid_input_fmu, rtol=1e-9, output=["h", "dl"], values={"phi": 2 * math.pi})
    c = simulate(rigid_input_fmu, rtol=1e-9, output=["h"], values={"phi": math.pi})
    return {"sum_h": float(np.max(np.abs(a.y["h"] + b.y["h"]))),
            "diff_dl": float(np.max(np.abs(a.y["dl"] - b.y["dl"]))),
            "h0_pi": float(c.y["h"][0]), "h0_2pi": float(b.y["h"][0]),
            "h0": float(a.y["h"][0])}


def markdown(errors, dflt, opp) -> str:
    """docs/guides/heald_tension_input.md."""
    rows = "\n".join(f"| {dt:g} | " + " | ".join(f"{e[n]:.2e}" for n in SLATS) + " |"
                     for dt, e in errors.items())
    return f"""# Heald frame with the warp tension as an input

Generated by `loomfmu heald tension-input` (module `loomfmu.heald.tension_input`).
Build option `warp_tension="input"` of `heald_frame`, `heald_frame_planar`
and `heald_frame_rigid`; see [heald_frame.md](heald_frame.md#warp-tension-as-an-input).

## Fed the geometry tension, it follows the geometry model

The spatial FMU with the tension as an input runs beside the default one
(tension from the shed geometry); before each communication step its T is
set to the default FMU's T and held over the step. Max |difference| over one
frame cycle (two revolutions, 0.209 s), relative to the default FMU's range:

| communication step (s) | {' | '.join(SLATS)} |
|---|---|---|---|
{rows}

The difference is that of the held tension: first order in the step. A
scene that couples the frame to a backrest pays the same unless it
extrapolates the tension (input derivatives).

## Defaults shared with the backrest

| figure | value |
|---|---|
| warp ends per frame n_n (seed 000) | {dflt['n_n']:g} |
| tension per end at the closed shed (dl = 0), T_min | {dflt['T_min']:g} N |
| tension per end at the open shed, T_max | {dflt['T_max']:g} N |
| time mean of the tension per end over a frame cycle, constant speed | {dflt['T_end_mean']:.4f} N |
| shed elongation at the open shed, dl_max | {dflt['dl_max'] * 1e3:.4f} mm |
| stiffness of one frame's ends implied by the tension law, n_n (T_max - T_min)/dl_max | {dflt['k_ends']:.4g} N/m |
| main-shaft speed ω (seed 000) | {dflt['omega']:g} rad/s = {dflt['omega_rpm']:.1f} rpm |

## The second frame of a plain weave

One stroke per revolution (up in odd, down in even revolutions), so the
frame in opposition is the same model started one revolution later:
with φ(0) = 2π, max |h_A + h_B| = {opp['sum_h']:.1e} m and max |dl_A − dl_B| =
{opp['diff_dl']:.1e} m over two frame cycles (h_A(0) = {opp['h0'] * 1e3:.1f} mm,
h_B(0) = {opp['h0_2pi'] * 1e3:.1f} mm). φ(0) = π is a frame half-way through its
stroke (h(0) = {opp['h0_pi'] * 1e3:.1f} mm), not one in opposition.
"""
