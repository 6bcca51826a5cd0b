"""The Gymnasium envs: thin adapters (action -> position -> rate -> reward) over the model.

- ``core``: ``UAVEnv`` and ``UAVVectorEnv``, the one env class and the one vector class of every
  single- and multi-node id; the view chooses a stepper (``core.stepper``) and the vector's rows;
- ``single_node`` / ``single_drawn``: the v0 view's steppers (one ground node, a fixed or a drawn
  scenario), ``single_rows`` their rows in the batched env, ``single_kernels`` the step they
  share (compiled with numba if installed); ``single`` / ``random_env`` / ``single_vector``: the
  presets ``IOSUAVEnv``, ``RandomIOSUAVEnv`` and their vector classes (with the v0 contract);
- ``multi_node`` / ``node_rows`` / ``multi_kernels``: the same for K >= 1 ground nodes (the node
  blocks; ``multi`` / ``multi_vector``: the presets ``MultiNodeEnv``, ``MultiNodeVectorEnv``;
  ``multi_table``: the kernels' columns and ``info`` keys; ``multi_features``: the feature names
  and the share map; ``multi_energy``: the energy objective and the Rician channel);
- ``batched``: ``BatchedEnv``, the base of the batched env (rows, seeding, autoreset, info);
- ``single_mobile`` / ``multi_mobile`` (with ``knowledge``): moving, roughly known nodes;
  ``mobile_draws`` / ``node_draws``: a batch's randomised moving episodes drawn in compiled calls,
  their row envs building their scenarios when read (``deferral``); ``node_weights``: each slot's
  node kernels computed in the rows; ``node_measure``: their measured rates (one compiled call over
  the rows); ``multi_space``: the multi-node observation space;
- ``observation``, ``options``, ``guard``: the observation layout (and ``require_features``,
  the check of a layout by feature name), the env options and the arrival guard;
  ``settings``: what each env supports, checked at construction; ``registration``: the ids,
  registered on ``import ios_uav_env``;
- ``rollout`` runs a policy for one episode; ``policies`` holds reference policies;
  ``rendering`` / ``rendering_multi`` draw a frame (matplotlib, imported lazily).
"""
