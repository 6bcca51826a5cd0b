"""The Gymnasium envs: thin adapters (action -> position -> rate -> reward) over the model.

- ``single`` / ``random_env``: one ground node, a fixed or a random scenario; ``single_vector``
  their batched form; ``single_kernels`` the step they share (compiled with numba if installed);
- ``multi`` / ``multi_vector`` / ``multi_kernels``: the same for K >= 1 ground nodes
  (``multi_table``: the kernels' columns and ``info`` keys; ``multi_features``: the feature
  names and the share map; ``multi_energy``: the energy objective and the Rician channel);
- ``batched``: ``BatchedEnv``, the base of both batched envs (rows, seeding, autoreset, info);
- ``single_mobile`` / ``multi_mobile`` (with ``knowledge``): moving, roughly known nodes;
  ``multi_space``: the multi-node observation space;
- ``observation``, ``options``, ``guard``: the observation layout (and ``require_features``,
  the check of a layout by feature name), the env options and the arrival guard;
  ``settings``: what each env supports, checked at construction; ``registration``: the ids,
  registered on ``import ios_uav_env``;
- ``rollout`` runs a policy for one episode; ``policies`` holds reference policies;
  ``rendering`` / ``rendering_multi`` draw a frame (matplotlib, imported lazily).
"""
