"""One env class and one vector class for every single- and multi-node world.

- ``env``: ``UAVEnv``, the Gymnasium env; its world and view choose a stepper (``stepper``);
- ``vector``: ``UAVVectorEnv``, the natively batched env; its template's view chooses a row batch
  (``ios_uav_env.envs.single_rows``, ``ios_uav_env.envs.node_rows``);
- ``stepper``: the stepper's interface, the views and their actions, and the one choice of a
  stepper from the arguments;
- ``kernel``: the row-step core that both views' compiled steps inline (the core columns of
  ``state`` and ``episode``, the flags; the move, arrival guard, power and reward assembly).
"""
