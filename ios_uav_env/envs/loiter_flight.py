"""The loiter flight, a pure flight rule of the model (:mod:`ios_uav_env.model.flights`),
re-exported here where the energy env's ``energy_reference="loiter"`` and users' code import it."""

from ios_uav_env.model.flights import best_loiter_path, cruise_speed, loiter_centre, loiter_path

__all__ = ["best_loiter_path", "cruise_speed", "loiter_centre", "loiter_path"]
