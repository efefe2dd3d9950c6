"""The vocabulary the ECU, the simulator and the cloud share: what each of them reads and writes.

- :mod:`pacc.vocab.dgpt` — the Driving Gap Preference Table and its safety bounds.
- :mod:`pacc.vocab.dgpt_file` — the DGPT's JSON file format on bytes, streams and paths.
- :mod:`pacc.vocab.triplog` — ``Trip``, a car-following trip as arrays.
- :mod:`pacc.vocab.triplog_file` — the MCAP trip-log format on bytes, streams and paths.
- :mod:`pacc.vocab.tripmode` — ``TripMode`` (manual, acc, takeover) and the one classifier.
- :mod:`pacc.vocab.acc_state` — the ACC's engagement state and fault codes.
- :mod:`pacc.vocab.pedals` — ``PedalScale``, pedal fractions from the DBC's full scale.
- :mod:`pacc.vocab.sampling` — how manual car-following is sampled (``keep_sample``, limits).
- :mod:`pacc.vocab.mcap_errors` — one mapping of MCAP read errors to a reader's error.
- :mod:`pacc.vocab.plugins` — finding methods by name: built-ins, Python entry points and
  ``module:attribute``.

Every error raised here derives from :class:`FormatError` (a :class:`pacc.errors.PaccError`).
"""

from __future__ import annotations

from pacc.errors import PaccError


class FormatError(PaccError):
    """Root of the errors of the shared formats: a table or a trip log that is not valid."""


__all__ = ["FormatError"]
