"""Where the IRL's demonstrations come from, as :class:`dbc.vocab.triplog.Trip` objects:
:mod:`cloud_sync.irl.sources.tripfiles` (``.mcap``/``.csv`` files),
:mod:`cloud_sync.irl.sources.bus_demos` (a real car's bus log) and
:mod:`cloud_sync.irl.sources.synthetic` (a follower whose answer is known).
"""
