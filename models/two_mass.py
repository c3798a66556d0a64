"""Two masses coupled by a spring-damper, split into two FMUs: the canonical
co-simulation benchmark with an exact answer (force-displacement coupling).

    m1 x1'' = -k1 x1 - d1 x1' - F          (mass 1, wall spring k1, damper d1)
    m2 x2'' = -k2 x2 - d2 x2' + F          (mass 2, wall spring k2, damper d2)
    F = kc (x1 - x2) + dc (x1' - x2')      (coupling spring-damper: force on mass 2)

build(side="force") holds mass 1 and the coupling element: it takes the
position and velocity of mass 2 as inputs and returns the coupling force F
(direct feedthrough: F depends on the inputs).  build(side="displacement")
holds mass 2: it takes F as input and returns its position and velocity (no
feedthrough).  Their ports, both of kind "translational" (roles position,
velocity, force), connect to each other both ways: each role is an output on
one side and an input on the other.

Both subsystems are linear with constant coefficients, so with inputs held
constant over a communication step they integrate exactly by a matrix
exponential; the co-simulated trajectory is then a linear map per step
(derivation and stability: docs/guides/scenes.md, loomfmu.machines.two_mass).
"""
from __future__ import annotations

from loomfmu.declare.checks import check_choice
from loomfmu.declare.model import Model

#: the source of every value: the benchmark has no seed; these are chosen
A = ("assumption: canonical two-mass co-simulation benchmark (Kuebler & Schiehlen 2000; "
     "Busch 2016), value chosen so the masters' stability limits fall between 1 ms and 0.1 s")
#: the two FMUs the system is split into
SIDES = ("force", "displacement")


def build(*, side: str = "force") -> Model:
    """side: "force" (mass 1 and the coupling spring-damper; position and
    velocity of mass 2 in, coupling force out) or "displacement" (mass 2;
    force in, its position and velocity out)."""
    check_choice("side", side, SIDES)
    return _force_side() if side == "force" else _displacement_side()


def _force_side() -> Model:
    m = Model("two_mass_force", description="Two-mass benchmark, force side: mass 1 on a "
              "wall spring-damper and the coupling spring-damper; position and velocity of "
              "mass 2 in, coupling force out", stop_time=10.0, step_size=1e-3, h_fixed=1e-4,
              options={"side": "force"})
    P = m.parameter
    m1 = P("m1", 1.0, unit="kg", description="mass 1", min=1e-6, max=1e6, source=A)
    k1 = P("k1", 100.0, unit="N/m", description="wall spring of mass 1", min=0.0, max=1e9,
           source=A)
    d1 = P("d1", 2.0, unit="N.s/m", description="wall damper of mass 1", min=0.0, max=1e9,
           source=A)
    kc = P("kc", 1000.0, unit="N/m", description="coupling spring", min=0.0, max=1e9,
           source=A)
    dc = P("dc", 1.0, unit="N.s/m", description="coupling damper", min=0.0, max=1e9,
           source=A)
    x2 = m.input("x2_in", 0.0, unit="m", description="position of mass 2")
    v2 = m.input("v2_in", 0.0, unit="m/s", description="velocity of mass 2")
    x1 = m.state("x1", 0.1, unit="m", description="position of mass 1 from its rest point")
    v1 = m.state("v1", 0.0, unit="m/s", description="velocity of mass 1")
    F = kc * (x1 - x2) + dc * (v1 - v2)
    m.eq(m.der(x1), v1)
    m.eq(m1 * m.der(v1), -k1 * x1 - d1 * v1 - F)
    m.output("F_c", F, unit="N", description="coupling force on mass 2 (minus the force "
             "on mass 1)")
    m.output("x1_out", x1, unit="m", description="position of mass 1")
    m.output("v1_out", v1, unit="m/s", description="velocity of mass 1")
    m.port("coupling", "translational", position="x2_in", velocity="v2_in", force="F_c",
           description="the coupling spring-damper's far end (mass 2)")
    return m


def _displacement_side() -> Model:
    m = Model("two_mass_displacement", description="Two-mass benchmark, displacement side: "
              "mass 2 on a wall spring-damper; coupling force in, its position and velocity "
              "out", stop_time=10.0, step_size=1e-3, h_fixed=1e-4,
              options={"side": "displacement"})
    P = m.parameter
    m2 = P("m2", 1.0, unit="kg", description="mass 2", min=1e-6, max=1e6, source=A)
    k2 = P("k2", 100.0, unit="N/m", description="wall spring of mass 2", min=0.0, max=1e9,
           source=A)
    d2 = P("d2", 2.0, unit="N.s/m", description="wall damper of mass 2", min=0.0, max=1e9,
           source=A)
    # start 1 N: run alone (build_fmu.py's verification) mass 2 answers a
    # constant push; in a scene the connection sets it from the start
    F = m.input("F_in", 1.0, unit="N", description="coupling force on mass 2")
    x2 = m.state("x2", 0.0, unit="m", description="position of mass 2 from its rest point")
    v2 = m.state("v2", 0.0, unit="m/s", description="velocity of mass 2")
    m.eq(m.der(x2), v2)
    m.eq(m2 * m.der(v2), -k2 * x2 - d2 * v2 + F)
    m.output("x2_out", x2, unit="m", description="position of mass 2")
    m.output("v2_out", v2, unit="m/s", description="velocity of mass 2")
    m.port("coupling", "translational", position="x2_out", velocity="v2_out", force="F_in",
           description="mass 2, where the coupling spring-damper acts")
    return m
