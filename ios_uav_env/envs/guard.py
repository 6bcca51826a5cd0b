"""The arrival guard of the envs' step: the model's (:mod:`ios_uav_env.model.guard`), re-exported
here where the envs and users' code import it."""

from ios_uav_env.model.guard import REACH_MARGIN, guarded_position, project_to_disks

__all__ = ["REACH_MARGIN", "guarded_position", "project_to_disks"]
