"""Where the IRL's demonstrations come from: each module yields :class:`dbc.vocab.triplog.Trip`
objects, which :mod:`cloud_sync.irl.demos` cuts into segments.

- :mod:`cloud_sync.irl.sources.tripfiles` — trip files by suffix (``.mcap`` trip logs, ``.csv``
  pairs).
- :mod:`cloud_sync.irl.sources.bus_demos` — demonstrations from a real car's bus log: the
  manual car-following stretches as trip logs.
- :mod:`cloud_sync.irl.sources.synthetic` — a small synthetic car follower with a known gap
  preference: demonstrations whose answer is known, for the IRL tests and the cloud benchmark
  (bench/sync.py).
"""
