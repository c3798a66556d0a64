"""Machine values of the spindle drive with pure delay (seed 001).

The seed gives symbols only, no numbers: every default below is an
assumption, taken from ``docs/guides/seed_notes/drive_spec.md`` section 4 (with the range
given there and its reason).  Internal units are SI with the spindle speed in
rev/s; rpm appear only at the edges (:data:`RPM`), rad/s in the drive FMU
(:data:`RAD_S`: its speeds are rad/s, shown in rpm).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, fields

from loomfmu.declare.checks import check_names, is_real

#: rev/s per rpm
RPM = 1.0 / 60.0
#: rad/s per rev/s (the drive FMU's speeds are rad/s)
RAD_S = 2.0 * math.pi

#: the range each field has as a parameter of the drive FMU (models/drive.py
#: declares its parameters with these bounds): name -> (lo, hi, FMU unit,
#: FMU units per unit of this class).  tau's upper bound in an FMU is its
#: ``max_delay`` option, at most 3600 s.
FMU_RANGES = {
    "K": (RAD_S / 60.0, 1e6 * RAD_S / 60.0, "rad/(s.V)", RAD_S),  # 1 ... 1e6 rpm/V
    "T": (1e-6, 100.0, "s", 1.0),
    "tau": (0.0, 3600.0, "s", 1.0),
    "k_g": (1e-3, 1e6, "V/m", 1.0),
    "r_min": (0.0, 1.0, "m", 1.0),
    "n_min": (RAD_S / 60.0, 1e5 * RAD_S / 60.0, "rad/s", RAD_S),  # 1 ... 1e5 rpm
}


def _f(default: float, unit: str, description: str, source: str):
    return field(default=default, metadata=dict(unit=unit, description=description,
                                                 source=source))


@dataclass(frozen=True)
class DriveParams:
    """Winding geometry, speed law, drive and layer sensor (seed 001).

    Every field is SI; speeds are rev/s (s^-1).  Each field's metadata holds
    its unit, description and source (:meth:`table`).  Construction validates
    the values (:meth:`validate`).
    """

    D_B: float = _f(0.020, "m", "inner cop diameter = bobbin-tube diameter at the winding cone",
                    "seed 001 eq. (2), (5) (D_б); assumption: 20 mm, usual cotton tube (18-25 mm)")
    D_N: float = _f(0.042, "m", "outer cop diameter (full cone base)",
                    "seed 001 eq. (2), (5) (D_н); assumption: ring 45 mm minus 3 mm (38-56 mm)")
    n_min: float = _f(12000.0 * RPM, "rev/s", "spindle speed at d = D_B",
                      "seed 001 eq. (5), (7); assumption: 12 000 rpm, cf. seed 003 (10-20 krpm)")
    n_max: float = _f(15000.0 * RPM, "rev/s", "spindle speed at d = D_N",
                      "seed 001 eq. (5), (6); assumption: 15 000 rpm (n_max/n_min = 1.25)")
    T_c: float = _f(10.0, "s", "actual layer duration (slow stroke, d: D_N -> D_B) under n0(t)",
                    "seed 001 eq. (6), (8), defect D12; assumption: 10 s (6-20 s)")
    T_n: float = _f(5.0, "s", "actual interlayer duration (fast stroke, d: D_B -> D_N)",
                    "seed 001 eq. (7), (8), defect D12; assumption: 5 s (up:down 2:1)")
    K: float = _f(30.0, "(rev/s)/V", "static gain of the drive",
                  "seed 001 eq. (9); assumption: 1800 rpm/V (0-10 V <-> 0-18 000 rpm)")
    T: float = _f(2.0, "s", "time constant of the drive",
                  "seed 001 eq. (9); assumption: 2 s, ring-frame inertia (0.5-5 s)")
    tau: float = _f(0.5, "s", "pure delay of the drive (printed t, defect D9)",
                    "seed 001 eq. (9); assumption: 0.5 s (0.1-1.5 s)")
    k_g: float = _f(100.0, "V/m", "static gain of the layer sensor W_g = k_g/(T_g s + 1)",
                    "assumption: W_g not given in seed 001; 0.1 V/mm displacement transducer")
    T_g: float = _f(0.0, "s", "lag of the layer sensor",
                    "assumption: 0 (pure gain W_g = k_g); <= 0.02 s for real transducers")
    r_min: float = _f(0.050, "m", "datum radius of the layer cam where U_п = 0 (defect D10)",
                      "seed 001 eq. (3); assumption: 50 mm (30-80 mm)")

    def __post_init__(self):
        self.validate()

    def problems(self) -> list[str]:
        """Every out-of-range value, one message per problem (empty if valid)."""
        out = []
        for f in fields(self):
            v = getattr(self, f.name)
            if not is_real(v) or not math.isfinite(v):
                out.append(f"{f.name} must be a finite number, got {v!r}")
        if out:
            return out
        unit = {f.name: f.metadata["unit"] for f in fields(self)}
        positive = ("D_B", "n_min", "T_c", "T_n", "K", "k_g", "r_min")
        for name in positive:
            v = getattr(self, name)
            if v <= 0:
                out.append(f"{name} must be > 0 ({unit[name]}), got {v!r}")
        if self.T_g < 0:
            out.append(f"T_g must be >= 0 (s), got {self.T_g!r}")
        for name, (lo, hi, fmu_unit, scale) in FMU_RANGES.items():
            v = getattr(self, name)
            if (name not in positive or v > 0) and not lo <= v * scale <= hi:
                allowed = f"[{lo:g}, {hi:g}] {fmu_unit}"
                if scale != 1.0:
                    allowed += f" = [{lo / scale:g}, {hi / scale:g}] {unit[name]}"
                out.append(f"{name} must be in {allowed} (the drive FMU's range), got {v!r}")
        if self.D_N <= self.D_B:
            out.append(f"D_N must be > D_B = {self.D_B!r} m, got {self.D_N!r}")
        if self.n_max <= self.n_min:
            out.append(f"n_max must be > n_min = {self.n_min!r} rev/s, got {self.n_max!r}")
        return out

    def validate(self) -> None:
        """Raise ValueError listing every problem (field, allowed range, value)."""
        probs = self.problems()
        if probs:
            raise ValueError("DriveParams: " + "; ".join(probs))

    @classmethod
    def from_rpm(cls, **kw) -> "DriveParams":
        """Like the constructor, but n_min, n_max in rpm and K in rpm/V."""
        check_names("DriveParams.from_rpm", kw, [f.name for f in fields(cls)], what="fields")
        for name in ("n_min", "n_max", "K"):
            if name in kw and is_real(kw[name]):
                kw[name] = kw[name] * RPM
        return cls(**kw)

    def replace(self, **changes) -> "DriveParams":
        """A copy with ``changes`` (field names checked, values validated)."""
        check_names("changes", changes, [f.name for f in fields(self)], what="fields")
        return dataclasses.replace(self, **changes)

    @classmethod
    def table(cls) -> list[dict]:
        """name, default, unit, description, source of every field."""
        return [dict(name=f.name, default=f.default, **f.metadata) for f in fields(cls)]


_dataclass_init = DriveParams.__init__


def _checked_init(self, *args, **kw):
    """The dataclass constructor with unknown field names refused by ValueError."""
    names = [f.name for f in fields(DriveParams)]
    if len(args) > len(names):
        raise ValueError(f"DriveParams: {len(args)} positional values; allowed: at most "
                         f"{len(names)} ({', '.join(names)})")
    check_names("DriveParams", kw, names, what="fields")
    _dataclass_init(self, *args, **kw)


DriveParams.__init__ = _checked_init  # type: ignore[method-assign]


def check_params(p, name: str = "p") -> "DriveParams":
    """``p`` if it is a :class:`DriveParams` (ValueError otherwise)."""
    if not isinstance(p, DriveParams):
        raise ValueError(f"{name} = {p!r:.60}; allowed: a loomfmu.drive.DriveParams")
    return p
