"""Spindle studies (seed 003): calibration to the seed's natural frequencies,
the amplitude-vs-speed table, section V's parameter trends, charts.

    loomfmu rotor calibrate   # fit, write docs/results/spindle_calibration.md
    loomfmu rotor trends      # write docs/results/spindle_trends.md + charts
    loomfmu rotor charts      # Campbell, unbalance response, compliance
    loomfmu rotor all

The seed's frequencies are read as the three lowest *forward-whirl*
frequencies at 16 000 rpm without damping (the seed: "未计入阻尼阵",
gyroscopic terms included), empty bobbin (fill = 0) and full (fill = 1).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.optimize import least_squares

from loomfmu.declare.checks import check_bool, check_int, check_mapping, check_number
from loomfmu.spindle.analysis import (
    RPM,
    orbit_radius,
    unbalance_response,
    whirl_modes,
)

#: default output folders, relative to the working directory (``--out`` moves them)
DOCS = Path("docs/results")
CHARTS = DOCS / "spindle"
WORK_RPM = 16000.0
#: seed 003, section V(一)1: first three natural frequencies (rpm) at 16 000 rpm
SEED_FREQS = {"empty": (1893.0, 24015.0, 45664.0), "full": (1051.0, 18797.0, 29789.0)}
#: seed 003, section V(一)3: speed (1e4 rpm), A1 top (1e-3 m), A2 bottom (1e-4 m)
SEED_TABLE = {
    "speed_rpm": [1e4, 1.1e4, 1.3e4, 1.5e4, 1.6e4, 1.7e4, 1.8e4, 1.9e4, 2.0e4],
    "A1_m": [x * 1e-3 for x in (0.1488, 0.323, 0.2482, 0.2099, 0.2029, 0.2059, 0.2141,
                                0.1994, 0.1467)],
    "A2_m": [x * 1e-4 for x in (0.9390, 1.931, 1.3616, 0.8815, 0.5818, 1.1710, 0.6834,
                                1.660, 2.086)],
}
#: the unknowns of the calibration and their search bounds (log-space)
CAL_BOUNDS = {"E_t": (1.5e8, 5e10), "k_u": (1e4, 1e9), "k_f": (1e4, 1e9), "a_s": (1e-4, 1.5e-3),
              "m_b": (0.01, 0.1), "Id_b": (1e-5, 2e-3), "m_y": (0.02, 0.3),
              "Id_y": (1e-5, 4e-3), "m_p": (0.005, 0.3), "L_s": (0.05, 0.12)}
#: the assumed values the search starts from and is pulled toward (typical
#: D12-family spindle; docs/guides/spindle.md); independent of the model's
#: current (calibrated) defaults, so the command is repeatable
PRIOR = {"E_t": 3.0e9, "k_u": 1.0e6, "k_f": 1.0e6, "a_s": 3.5e-4, "m_b": 0.030,
         "Id_b": 1.3e-4, "m_y": 0.075, "Id_y": 2.1e-4, "m_p": 0.030, "L_s": 0.072}
#: weight of the pull toward the prior (assumed) values, per log unit
CAL_PRIOR_WEIGHT = 0.02


@dataclass
class Spindle:
    """Numeric access to the symbolic spindle of models/spindle.py."""

    options: dict

    def __post_init__(self):
        import inspect

        from loomfmu.models.spindle import declare_rotor, spindle_system
        allowed = [p.name for p in inspect.signature(declare_rotor).parameters.values()
                   if p.kind is inspect.Parameter.KEYWORD_ONLY]
        self.options = check_mapping("options", self.options, allowed,
                                     what="spindle build options", numbers_only=False)
        self.model, self.sp = spindle_system(**self.options)
        self.names = [v.name for v in self.model.of_kind("parameter")]
        self.defaults = dict(zip(self.names, self.model.starts("parameter")))
        self._f = ca.Function("mats", [self.model.syms("parameter"), self.sp.Omega],
                              [self.sp.M, self.sp.C, self.sp.G, self.sp.K])
        self.xi, self.yi = self.sp.plane_indices()

    def values(self, **overrides) -> dict:
        """The default parameters with ``overrides`` (names and ranges checked)."""
        overrides = check_mapping("overrides", overrides, self.names,
                                  what="spindle parameters")
        for name, value in overrides.items():
            self.model.var(name).check_value(value)
        return {**self.defaults, **overrides}

    def matrices(self, Omega: float, values: dict | None = None):
        """(M, C, G, K) at spin speed Omega (rad/s) for ``values`` (parameters;
        default: the defaults)."""
        check_number("Omega", Omega, unit="rad/s")
        v = self.values(**check_mapping("values", values, self.names,
                                        what="spindle parameters"))
        return [np.array(a) for a in self._f([v[n] for n in self.names], Omega)]

    def forward_freqs_rpm(self, values=None, speed_rpm=WORK_RPM, n=3, damped=False):
        """The n lowest forward-whirl frequencies (rpm) at speed_rpm (>= 0)."""
        speed_rpm = check_number("speed_rpm", speed_rpm, lo=0.0, unit="rpm")
        n = check_int("n", n, lo=1, hi=1000)
        damped = check_bool("damped", damped)
        M, C, G, K = self.matrices(speed_rpm * RPM, values)
        Om = speed_rpm * RPM
        modes = whirl_modes(M, (C if damped else 0 * C) + Om * G, K, self.xi, self.yi)
        f = [md.freq / RPM for md in modes if md.forward][:n]
        return np.array(f + [np.nan] * (n - len(f)))

    def critical_speeds(self, values=None, max_rpm=40000.0, n=3,
                        scan_rpm=250.0) -> list[float]:
        """The spin speeds (rpm, ascending, up to max_rpm) at which one of the
        n lowest forward-whirl frequencies equals the spin speed: where the
        unbalance, which turns with the spindle, excites a mode.  Found on a
        scan every scan_rpm, each crossing refined by Brent's method to
        1e-3 rpm; values: parameters (default the defaults; fill selects the
        bobbin)."""
        from scipy.optimize import brentq
        max_rpm = check_number("max_rpm", max_rpm, lo=0.0, lo_open=True, hi=1e6, unit="rpm")
        n = check_int("n", n, lo=1, hi=20)
        scan_rpm = check_number("scan_rpm", scan_rpm, lo=1.0, hi=max_rpm, unit="rpm")
        v = self.values(**check_mapping("values", values, self.names,
                                        what="spindle parameters"))

        def gap(s, j):
            return self.forward_freqs_rpm(v, speed_rpm=s, n=n)[j] - s
        speeds = np.append(np.arange(0.0, max_rpm, scan_rpm), max_rpm)
        d = np.array([self.forward_freqs_rpm(v, speed_rpm=s, n=n) for s in speeds]) - \
            speeds[:, None]
        found = []
        for j in range(n):
            for i in np.nonzero(np.sign(d[1:, j]) * np.sign(d[:-1, j]) < 0)[0]:
                found.append(brentq(gap, speeds[i], speeds[i + 1], args=(j,), xtol=1e-3))
        return sorted(found)

    def unbalance(self, speed_rpm, values=None, e_b=5e-6, e_w=5e-6):
        """Orbit radii (top, bottom) from (15) for the bobbin's and whorl's
        unbalance m e Omega^2, in phase (F_x = U w^2 cos wt, F_y = U w^2 sin wt).
        speed_rpm: >= 0; e_b, e_w: eccentricities (m, >= 0)."""
        v = self.values(**check_mapping("values", values, self.names,
                                        what="spindle parameters"))
        speed_rpm = check_number("speed_rpm", speed_rpm, lo=0.0, unit="rpm")
        e_b = check_number("e_b", e_b, lo=0.0, unit="m")
        e_w = check_number("e_w", e_w, lo=0.0, unit="m")
        w = speed_rpm * RPM
        M, C, G, K = self.matrices(w, v)
        n = M.shape[0]
        P1, P2 = np.zeros(n), np.zeros(n)
        mb = v["m_b"] + v["fill"] * v["m_y"]
        for node, U in ((self.sp.nodes["bobbin"], mb * e_b), (self.sp.nodes["whorl"],
                                                                v["m_w"] * e_w)):
            P2[self.sp.idx(f"n{node}.x")] += U * w**2   # cos wt
            P1[self.sp.idx(f"n{node}.y")] += U * w**2   # sin wt
        A1, A2 = unbalance_response(M, C + w * G, K, w, P1, P2)
        top, bot = self.sp.nodes["top"], 0
        return (orbit_radius(A1, A2, self.sp.idx(f"n{top}.x"), self.sp.idx(f"n{top}.y")),
                orbit_radius(A1, A2, self.sp.idx(f"n{bot}.x"), self.sp.idx(f"n{bot}.y")))


def _check_spindle(sp) -> Spindle:
    if not isinstance(sp, Spindle):
        raise ValueError(f"sp = {sp!r:.60}; allowed: a Spindle")
    return sp


# ------------------------------------------------------------------ calibration
def calibrate(sp: Spindle | None = None) -> dict:
    """Fit CAL_BOUNDS' unknowns to SEED_FREQS (log-frequency least squares
    with a weak pull to the assumed values).  Returns the fit and the table."""
    sp = Spindle({}) if sp is None else _check_spindle(sp)
    keys = list(CAL_BOUNDS)
    prior = np.log([PRIOR[k] for k in keys])
    lo = np.log([CAL_BOUNDS[k][0] for k in keys])
    hi = np.log([CAL_BOUNDS[k][1] for k in keys])
    target = np.log(np.concatenate([SEED_FREQS["empty"], SEED_FREQS["full"]]))

    def model_freqs(z):
        vals = dict(zip(keys, np.exp(z)))
        return np.concatenate([sp.forward_freqs_rpm(sp.values(**vals, fill=0.0)),
                               sp.forward_freqs_rpm(sp.values(**vals, fill=1.0))])

    def resid(z):
        f = model_freqs(z)
        r = np.where(np.isfinite(f), np.log(np.abs(f) + 1e-9) - target, 5.0)
        return np.concatenate([r, CAL_PRIOR_WEIGHT * (z - prior)])

    best = None
    for start in (prior, (lo + hi) / 2, prior + 0.5 * (hi - prior), prior + 0.5 * (lo - prior)):
        sol = least_squares(resid, np.clip(start, lo + 1e-9, hi - 1e-9), bounds=(lo, hi),
                            x_scale=1.0, diff_step=1e-4, max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
    fitted = dict(zip(keys, np.exp(best.x)))
    f = model_freqs(best.x)
    seed = np.concatenate([SEED_FREQS["empty"], SEED_FREQS["full"]])
    rows = [{"case": case, "mode": i + 1, "seed_rpm": float(seed[3 * c + i]),
             "model_rpm": float(f[3 * c + i]),
             "error_pct": float(100 * (f[3 * c + i] / seed[3 * c + i] - 1))}
            for c, case in enumerate(("empty", "full")) for i in range(3)]
    return {"fitted": fitted, "rows": rows, "cost": float(best.cost)}


def amplitude_table(sp: Spindle, fill: float) -> dict:
    """The seed's amplitude-vs-speed table against the model; the unbalance
    (equal eccentricity of bobbin and whorl) is scaled to the seed's top
    amplitude by least squares in log (one factor: the seed gives no unbalance).
    fill: bobbin fill, in the parameter's range."""
    v = _check_spindle(sp).values(fill=fill)
    speeds = SEED_TABLE["speed_rpm"]
    e = 1e-6
    raw = np.array([sp.unbalance(n, v, e_b=e, e_w=e) for n in speeds])
    a1 = np.array(SEED_TABLE["A1_m"])
    scale = float(np.exp(np.mean(np.log(a1) - np.log(raw[:, 0]))))
    rows = [{"speed_rpm": n, "A1_seed": s1, "A1_model": scale * r[0],
             "A2_seed": s2, "A2_model": scale * r[1]}
            for n, s1, s2, r in zip(speeds, a1, SEED_TABLE["A2_m"], raw)]
    return {"eccentricity_m": scale * e, "fill": fill, "rows": rows}


def write_calibration(out: Path = DOCS / "spindle_calibration.md") -> dict:
    sp = Spindle({})
    cal = calibrate(sp)
    calibrated = Spindle({})
    for k, v in cal["fitted"].items():
        calibrated.defaults[k] = v
    tables = {f: amplitude_table(calibrated, f) for f in (0.0, 1.0)}
    lines = ["# Spindle calibration (seed 003)", "",
             "Generated by `loomfmu rotor calibrate`.  Forward-whirl natural "
             "frequencies at 16 000 rpm, no damping, gyroscopic terms included.", "",
             "## Fitted parameters", "", "| parameter | assumed start | fitted | bounds |",
             "|---|---|---|---|"]
    for k, v in cal["fitted"].items():
        lines.append(f"| `{k}` | {PRIOR[k]:.4g} | {v:.4g} | "
                     f"[{CAL_BOUNDS[k][0]:.3g}, {CAL_BOUNDS[k][1]:.3g}] |")
    lines += ["", "## Natural frequencies: model vs seed", "",
              "| bobbin | mode | seed (rpm) | model (rpm) | error |", "|---|---|---|---|---|"]
    for r in cal["rows"]:
        lines.append(f"| {r['case']} | {r['mode']} | {r['seed_rpm']:.0f} | "
                     f"{r['model_rpm']:.0f} | {r['error_pct']:+.1f} % |")
    for fill, t in tables.items():
        lines += ["", f"## Amplitude vs speed, {'full' if fill else 'empty'} bobbin "
                  f"(eccentricity of bobbin and whorl {t['eccentricity_m'] * 1e6:.2f} um, "
                  "fitted to the seed's A1)", "",
                  "| speed (rpm) | A1 seed (mm) | A1 model (mm) | A2 seed (mm) | "
                  "A2 model (mm) |", "|---|---|---|---|---|"]
        for r in t["rows"]:
            lines.append(f"| {r['speed_rpm']:.0f} | {r['A1_seed'] * 1e3:.4f} | "
                         f"{r['A1_model'] * 1e3:.4f} | {r['A2_seed'] * 1e3:.4f} | "
                         f"{r['A2_model'] * 1e3:.4f} |")
    out.parent.mkdir(parents=True, exist_ok=True)
    lines += ["", "Model defaults (`CALIBRATED` in models/spindle.py) to paste:", "",
              "    " + ", ".join(f'"{k}": {v:.4g}' for k, v in cal["fitted"].items())]
    out.write_text("\n".join(lines) + "\n")
    result = {"calibration": cal, "amplitudes": tables}
    (out.with_suffix(".json")).write_text(json.dumps(result, indent=1))
    print("\n".join(lines))
    return result
