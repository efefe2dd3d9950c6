"""The recorder's writer process: a file-only recording written off the node's thread.

- :mod:`ecu.buslog.process.remote` — the node's side: a recording's output sent to a writer
  process, the same bytes as the node's thread would write.
- :mod:`ecu.buslog.process.writers` — the pool of writer processes: started, made ready, kept
  idle between recordings, ended and reaped.
- :mod:`ecu.buslog.process.serve` — the writer process's side (``python -m
  ecu.buslog.process.serve``, started by the pool, never by hand): the calls it gets, run on a
  :class:`~ecu.buslog.output.LogOutput`.
"""
