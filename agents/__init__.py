"""RL agents for ios_uav_env, run from a checkout: training (``train.py``, :mod:`agents.training`),
zoo-format hyperparameters (``agents/hyperparams``), the one loader of trained agents
(:mod:`agents.loading`), evaluation against the planners (``python -m agents.evaluate``), the
held-out suite of generalists (``python -m agents.suite``) and the shipped models
(``agents/models``)."""
