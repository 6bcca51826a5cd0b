"""RL agents for ios_uav_env: training (``train.py``, :mod:`agents.training`), zoo-format
hyperparameters (``agents/hyperparams``), evaluation against the planners
(``python -m agents.evaluate``) and the shipped models (``agents/models``)."""
