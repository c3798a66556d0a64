"""SI units known to loomfmu, as FMI ``BaseUnit`` exponents.

Every unit a model uses must be listed here, so that ``modelDescription.xml``
carries a ``UnitDefinitions`` entry for it.  The empty string means
dimensionless (no ``unit`` attribute is written).
"""
from __future__ import annotations

import re

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
    "rad/(s.V)": {"rad": 1, "kg": -1, "m": -2, "s": 2, "A": 1},
    "rad/(s.m)": {"rad": 1, "m": -1, "s": -1},
    "1/s": {"s": -1},
}


def check_unit(unit: str) -> None:
    """Raise ValueError for a unit loomfmu cannot describe in the XML."""
    if not isinstance(unit, str):
        raise ValueError(f"unit = {unit!r:.60}; allowed: a unit name (string) from "
                         f"{sorted(UNITS)}")
    if unit and unit not in UNITS:
        raise ValueError(f"unit {unit!r} is not defined; known units: {sorted(UNITS)}")


def factor(unit: str) -> float:
    """value in SI = factor(unit) * value in ``unit`` (1 for SI units)."""
    check_unit(unit)
    return float(UNITS[unit].get("factor", 1.0)) if unit else 1.0


def display_factor(unit: str, display_unit: str) -> float:
    """The FMI ``DisplayUnit`` factor of ``display_unit`` under ``unit``.

    FMI 2.0 and 3.0 define a ``<DisplayUnit name factor offset>`` of a
    ``<Unit>`` by

        value_in_display_unit = factor * value_in_unit + offset

    (FMI 2.0.3, section 2.2.2 "Definition of Units"; FMI 3.0, section 2.4.3
    "Definition of Units", which adds ``inverse``, not used here).  With
    value_SI = f_u * value_unit = f_d * value_display (``factor`` of UNITS),
    factor = f_u / f_d and offset = 0: rpm under rad/s has
    factor = 1 / (2 pi / 60) = 9.549...  An FMU gets and sets values in the
    variable's unit; the display unit is for people.
    """
    return factor(unit) / factor(display_unit)


def check_display_unit(display_unit: str, unit: str, what: str = "display_unit") -> str:
    """``display_unit`` if it is a unit of UNITS other than ``unit`` that
    measures the same quantity; "" means none.  Otherwise ValueError naming
    ``what`` and the allowed units."""
    if display_unit == "":
        return ""
    allowed = [u for u in units_for(unit) if u != unit]
    if not isinstance(display_unit, str) or display_unit not in allowed:
        raise ValueError(f"{what} = {display_unit!r:.40} for unit {unit!r}; allowed: "
                         f"{allowed or 'none (no other unit measures this quantity)'}")
    return display_unit


def units_for(unit: str) -> list[str]:
    """The units a value of a variable in ``unit`` may be given in: ``unit``
    first, then every unit of UNITS that measures the same quantity."""
    if not unit:
        return [""]
    return [unit] + sorted(u for u in UNITS if u != unit and same_quantity(u, unit))


def same_quantity(a: str, b: str) -> bool:
    """Whether units ``a`` and ``b`` (names in UNITS, "" dimensionless)
    measure the same quantity (equal base-unit exponents)."""
    def exps(u):
        entry = UNITS.get(u, {}) if u else {}
        return {k: v for k, v in entry.items() if k != "factor" and v}
    check_unit(a)
    check_unit(b)
    return exps(a) == exps(b)


_QUANTITY = re.compile(r"^\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S.*?)?\s*$")


def split_quantity(text: str) -> tuple[float, str] | None:
    """'240rpm' or '240 rpm' -> (240.0, 'rpm'); '25.1' -> (25.1, ''); None
    when ``text`` does not start with a number."""
    m = _QUANTITY.match(text) if isinstance(text, str) else None
    return (float(m.group(1)), m.group(2) or "") if m else None


def allowed_units(unit: str, display: dict | None = None) -> list[str]:
    """The units a value of a variable in ``unit`` may be given in: ``unit``,
    the display units ``display`` ({name: (factor, offset)}, as a model
    description defines them under ``unit``) and the units of UNITS that
    measure the same quantity."""
    out = [unit] if unit else []
    for u in [*(display or {}), *(units_for(unit)[1:] if unit in UNITS else [])]:
        if u not in out:
            out.append(u)
    return out


def to_unit(value: float, given: str, unit: str, display: dict | None = None) -> float:
    """``value`` given in unit ``given`` as a value in ``unit``.  display:
    the display units of ``unit`` ({name: (factor, offset)} with
    value_display = factor * value_unit + offset, FMI's definition, see
    :func:`display_factor`), e.g. from a model description; else the units
    of UNITS.  ValueError naming both units and the allowed ones when
    ``given`` does not measure what ``unit`` does."""
    if given == unit:
        return value
    if display and given in display:
        f, offset = display[given]
        return (value - offset) / f
    if given in UNITS and unit in UNITS and unit and same_quantity(given, unit):
        return value * factor(given) / factor(unit)
    allowed = allowed_units(unit, display)
    raise ValueError(f"unit {given!r:.40} does not measure what {unit or 'dimensionless'!r} "
                     f"does; allowed: {', '.join(allowed) if allowed else 'a plain number'}")


def show(value: float, unit: str, display_unit: str = "", display: dict | None = None,
         fmt: str = ".6g") -> str:
    """``value`` with its unit, and in its display unit too: '25.1327 rad/s
    (240 rpm)'.  display: {name: (factor, offset)} of ``unit`` (default:
    from UNITS)."""
    text = f"{value:{fmt}}" + (f" {unit}" if unit else "")
    if display_unit:
        f, offset = (display or {}).get(display_unit) or (display_factor(unit, display_unit),
                                                          0.0)
        text += f" ({f * value + offset:{fmt}} {display_unit})"
    return text
