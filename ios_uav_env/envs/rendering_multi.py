"""Figures for several ground nodes: the drawing helpers of :mod:`ios_uav_env.plotting` (the
best-node rate map, every node, trajectories coloured by the node each slot serves),
re-exported here where the multi-node env and users' code import them."""

from ios_uav_env.plotting import NODE_COLORS, plot_multinode_map, plot_served_trajectories, served_node

__all__ = ["NODE_COLORS", "plot_multinode_map", "plot_served_trajectories", "served_node"]
