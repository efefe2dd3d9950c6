"""``pacc bench``: the suite (:mod:`~sim_bus.study.bench.suite`), the held-out gap error
(:mod:`~sim_bus.study.bench.heldout`) and the leaderboard
(:mod:`~sim_bus.study.bench.leaderboard`)."""
