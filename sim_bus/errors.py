"""The exception tree of the simulator: one root, subclasses named by phase."""

from __future__ import annotations

from dbc.errors import PaccError


class SimError(PaccError):
    """Root of every error the simulator raises on purpose."""


class DataError(SimError):
    """The shipped data file is missing or malformed."""


class ScenarioError(SimError):
    """A scenario request or a profile file is invalid."""


class DriverError(SimError):
    """A driver definition (built-in name, TOML or JSON file) is invalid."""


class FaultSpecError(SimError):
    """A ``--faults`` specification cannot be parsed."""


class DriveError(SimError):
    """A closed-loop drive cannot be set up (missing table, bad option)."""
