"""The vocabulary the ECU, the simulator and the cloud share: what each of them reads and writes.

- :mod:`dbc.vocab.dgpt` — the Driving Gap Preference Table and its safety bounds.
- :mod:`dbc.vocab.dgpt_file` — the DGPT's JSON file format.
- :mod:`dbc.vocab.triplog` — ``Trip``, a car-following trip as arrays.
- :mod:`dbc.vocab.triplog_file` — the MCAP trip-log format.
- :mod:`dbc.vocab.tripmode` — ``TripMode`` (manual, acc, takeover) and the one classifier.
- :mod:`dbc.vocab.acc_state` — the ACC's engagement state and fault codes.
- :mod:`dbc.vocab.pedals` — ``PedalScale``, pedal fractions from the DBC's full scale.
- :mod:`dbc.vocab.sampling` — how manual car-following is sampled (``keep_sample``, limits).
- :mod:`dbc.vocab.mcap_errors` — one mapping of MCAP read errors to a reader's error.
- :mod:`dbc.vocab.plugins` — finding methods by name: built-ins, Python entry points and
  ``module:attribute``.

Every error raised here derives from :class:`FormatError` (a :class:`dbc.errors.PaccError`).
"""

from __future__ import annotations

from dbc.errors import PaccError


class FormatError(PaccError):
    """Root of the errors of the shared formats: a table or a trip log that is not valid."""


__all__ = ["FormatError"]
