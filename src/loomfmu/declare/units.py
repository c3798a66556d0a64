"""SI units known to loomfmu, as FMI ``BaseUnit`` exponents.

Every unit a model uses must be listed here, so that ``modelDescription.xml``
carries a ``UnitDefinitions`` entry for it.  The empty string means
dimensionless (no ``unit`` attribute is written).
"""
from __future__ import annotations

#: unit name -> BaseUnit exponents (kg, m, s, A, K, mol, cd, rad) and, for
#: non-SI units, "factor" (value in SI = factor * value in this unit)
UNITS: dict[str, dict[str, float]] = {
    "m": {"m": 1},
    "m2": {"m": 2},
    "m4": {"m": 4},
    "s": {"s": 1},
    "kg": {"kg": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "kg/m3": {"kg": 1, "m": -3},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
    "N/m": {"kg": 1, "s": -2},
    "N.s/m": {"kg": 1, "s": -1},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "m/N": {"kg": -1, "s": 2},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "Hz": {"s": -1},
    "rpm": {"rad": 1, "s": -1, "factor": 0.10471975511965977},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "V/m": {"kg": 1, "m": 1, "s": -3, "A": -1},
    "rpm/V": {"rad": 1, "kg": -1, "m": -2, "s": 2, "A": 1, "factor": 0.10471975511965977},
    "rpm/m": {"rad": 1, "m": -1, "s": -1, "factor": 0.10471975511965977},
    "1/s": {"s": -1},
}


def check_unit(unit: str) -> None:
    """Raise ValueError for a unit loomfmu cannot describe in the XML."""
    if not isinstance(unit, str):
        raise ValueError(f"unit = {unit!r:.60}; allowed: a unit name (string) from "
                         f"{sorted(UNITS)}")
    if unit and unit not in UNITS:
        raise ValueError(f"unit {unit!r} is not defined; known units: {sorted(UNITS)}")


def same_quantity(a: str, b: str) -> bool:
    """Whether units ``a`` and ``b`` (names in UNITS, "" dimensionless)
    measure the same quantity (equal base-unit exponents)."""
    def exps(u):
        entry = UNITS.get(u, {}) if u else {}
        return {k: v for k, v in entry.items() if k != "factor" and v}
    check_unit(a)
    check_unit(b)
    return exps(a) == exps(b)
