"""Bus recordings: every CAN frame raw and decoded, with node internals, in MCAP.

- :mod:`ecu.buslog.format` — topics, frame flags, block columns, the recording's errors.
- :mod:`ecu.buslog.blocks` — the block encoding: named columns as base64 arrays in JSON.
- :mod:`ecu.buslog.writer` — ``CanLogWriter``, the recorder.
- :mod:`ecu.buslog.reader` — reading a recording back: frames, decoded signals, internals.
- :mod:`ecu.buslog.plugin` — ``.mcap`` as a python-can log format (``can.LogReader``/``Logger``).
- :mod:`ecu.buslog.recording` — opening a recording for a node: attachments, replay metadata.
- :mod:`ecu.buslog.replay` — a recording through the ECU in lockstep, or onto a bus.
"""
