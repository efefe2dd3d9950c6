"""Physical units of DBC signals and their conversion to pacc's logical units.

A field states its unit in its name (``_mps`` m/s, ``_m`` m, ``_mps2`` m/s², ``_pct`` %,
``_bar`` bar; else dimensionless); a signal in the DBC or the binding. The codec folds the
factor into scale and offset once.
"""

from __future__ import annotations

#: logical unit of a field, by the suffix of its name (longest suffix first)
SUFFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("_mps2", "m/s^2"),
    ("_mps", "m/s"),
    ("_pct", "%"),
    ("_bar", "bar"),
    ("_m", "m"),
)

#: factor from a unit to the logical unit of its dimension (value_logical = value * factor)
FACTORS: dict[str, dict[str, float]] = {
    "m/s": {"m/s": 1.0, "km/h": 1 / 3.6, "kph": 1 / 3.6, "kmh": 1 / 3.6, "mph": 0.44704},
    "m/s^2": {"m/s^2": 1.0, "m/s2": 1.0, "m/s²": 1.0, "g": 9.80665},
    "m": {"m": 1.0, "cm": 0.01, "km": 1000.0, "ft": 0.3048},
    "%": {"%": 1.0, "1": 100.0},
    "bar": {"bar": 1.0, "kPa": 0.01, "MPa": 10.0, "Pa": 1e-5, "psi": 0.0689476},
}


class UnitError(ValueError):
    """A unit is unknown, or belongs to another dimension than the field's."""


def logical_unit(field: str) -> str | None:
    """The unit of logical field ``field`` (``"m/s"`` for ``speed_mps``), None if
    dimensionless."""
    return next((unit for suffix, unit in SUFFIX_UNITS if field.endswith(suffix)), None)


def conversion(field: str, unit: str | None) -> float:
    """Factor turning a value in ``unit`` into ``field``'s unit (1 for a dimensionless
    field); UnitError: ``unit`` missing, unknown or of another dimension."""
    target = logical_unit(field)
    if target is None:
        return 1.0
    if not unit:
        raise UnitError(f"field {field} is in {target}: the signal has no unit, give one")
    factors = FACTORS[target]
    if unit not in factors:
        known = ", ".join(factors)
        raise UnitError(f"field {field} is in {target}: unit {unit!r} is not one of {known}")
    return factors[unit]
