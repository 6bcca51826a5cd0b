"""The fast on-policy trainer: PPO on the batched env's arrays (``train.py --trainer fast``).

See ``docs/fast-training.md``. :class:`~agents.fast.ppo.FastPPO` is the algorithm (rollout,
GAE, update), :class:`~agents.fast.recipe.FastRecipe` its settings read from a zoo-format
entry, and :mod:`agents.fast.run` the training run (the run folder, checkpoints, resume,
interrupts) that ``agents.training.train`` calls for ``TrainSettings(trainer="fast")``.
:mod:`agents.fast.fleet` runs it as IPPO with shared parameters on B fleets of U UAVs
(``FastPPO(FleetSpec(...), ...)``) and :mod:`agents.fast.fleet_run` writes such a run's folder.
"""

from agents.fast.gae import gae
from agents.fast.ppo import FastPPO
from agents.fast.recipe import FastRecipe, Schedule

__all__ = ["FastPPO", "FastRecipe", "Schedule", "gae"]
