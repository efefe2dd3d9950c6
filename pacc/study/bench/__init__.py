"""``pacc bench``: the suite (:mod:`~pacc.study.bench.suite`), the held-out gap error
(:mod:`~pacc.study.bench.heldout`) and the leaderboard
(:mod:`~pacc.study.bench.leaderboard`)."""
