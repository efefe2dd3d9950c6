"""Bus recordings: every CAN frame raw and decoded, with node internals, in MCAP, and live.

- :mod:`ecu.buslog.format` — topics, frame flags, the time base, the ``foxglove.Log`` schema.
- :mod:`ecu.buslog.writer` — ``CanLogWriter``, the recorder: what a node feeds it, written at
  each flush to every sink by one code path.
- :mod:`ecu.buslog.decoded` — a flush's frames: the raw block and each DBC message's rows.
- :mod:`ecu.buslog.proto` — rows of numeric fields as protobuf messages, built with numpy.
- :mod:`ecu.buslog.blocks` — the block encoding of ``/can/raw``: columns as base64 arrays.
- :mod:`ecu.buslog.mcapfile` — a minimal MCAP writer taking a channel's messages at once.
- :mod:`ecu.buslog.sinks` — the sink interface and the file sink; :mod:`ecu.buslog.live` the
  Foxglove WebSocket sink (``--foxglove``).
- :mod:`ecu.buslog.reader` — reading a recording back (also one killed mid-run);
  :mod:`ecu.buslog.repair` — a killed recording made complete.
- :mod:`ecu.buslog.plugin` — ``.mcap`` as a python-can log format (``can.LogReader``/``Logger``).
- :mod:`ecu.buslog.recording` — opening a recording for a node: attachments, replay metadata.
- :mod:`ecu.buslog.replay` — a recording through the ECU in lockstep, or onto a bus.
"""
