"""Maximum-entropy IRL: a driver's DGPT learned from car-following demonstrations.

- :mod:`cloud_sync.irl.sources` — where the demonstrations come from, as trips: trip files by
  suffix, a real car's bus log, a synthetic follower (a sub-package).
- :mod:`cloud_sync.irl.demos` — trips to segments, feature counts and start states.
- :mod:`cloud_sync.irl.mdp` — the car-following MDP: grid, sparse transitions.
- :mod:`cloud_sync.irl.features` — the reward basis.
- :mod:`cloud_sync.irl.mce_irl` — soft value iteration, visitation, objective (pure).
- :mod:`cloud_sync.irl.model` — a fresh reward model or an earlier table's.
- :mod:`cloud_sync.irl.fit` — L-BFGS-B on the dual.
- :mod:`cloud_sync.irl.policy_gap` — the gap the learned policy keeps: the DGPT.
- :mod:`cloud_sync.irl.extract` — reward to table (argmax, low-pass, bounds), steady gaps.
- :mod:`cloud_sync.irl.blend` — coverage, evidence, blending into an earlier table.
- :mod:`cloud_sync.irl.config` — ``IrlConfig``, everything that decides a learned table.
- :mod:`cloud_sync.irl.baseline` — ``empirical_baseline``, the steady-state comparison table.
- :mod:`cloud_sync.irl.trainer` — ``learn_dgpt``, ``fine_tune``: compositions of the phases.
- :mod:`cloud_sync.irl.plot` — the figure of a learned table.
"""
