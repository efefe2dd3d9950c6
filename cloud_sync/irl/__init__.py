"""Maximum-entropy IRL: a driver's DGPT learned from car-following demonstrations.

Sources of trips (:mod:`cloud_sync.irl.sources`) -> :mod:`cloud_sync.irl.demos` (segments,
feature counts) on the MDP (:mod:`cloud_sync.irl.mdp`, :mod:`cloud_sync.irl.features`,
the reward model) -> :mod:`cloud_sync.irl.mce_irl` (the weights, and the gap their policy
keeps) -> :mod:`cloud_sync.irl.extract` (also the empirical comparison table) and
:mod:`cloud_sync.irl.blend` (the table). :mod:`cloud_sync.irl.trainer` composes them
under :mod:`cloud_sync.irl.config`; :mod:`cloud_sync.irl.plot` draws them.
"""
