"""Small declarations the tests share as oracles (their solutions are known
in closed form)."""
from __future__ import annotations

from loomfmu.declare.model import Model


def spring(name: str, *, stop_time: float = 2.0, k: float = 4.0,
           require: str | None = None) -> Model:
    """x'' = -k x from x = 1, v = 0 (x = cos(sqrt(k) t)), output x_out; with
    ``require`` the validity condition "taut", x_out + 0.5 >= 0, whose
    failure says ``require``."""
    m = Model(name, description="mass on a spring", stop_time=stop_time, step_size=0.01)
    kk = m.parameter("k", k, unit="N/m", description="stiffness per unit mass",
                     source="assumption: test oracle")
    x = m.state("x", 1.0, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="velocity")
    m.eq(m.der(x), v)
    m.eq(m.der(v), -kk * x)
    xo = m.output("x_out", x, unit="m", description="position")
    if require is not None:
        m.require("taut", xo + 0.5, require)  # through an output's symbol
    return m
