"""How closely a result computed here must match a number stored in the repository, and why.

## Shipped models replayed (``RATE_REL``, ``MISS_ABS``)

A shipped model is replayed on the user's machine, not on the one that trained it. Its actions
come from float32 matrix products (torch, or the numpy export on the machine's BLAS), whose
kernels differ by instruction set (AVX-512, AVX2, SSE, NEON): the same weights give actions that
differ by a few float32 ulps (~1e-7 relative). The episode is a closed loop, so the difference
is carried through every later observation, and the recorded rate is only reproduced to about
1e-8 relative on another CPU (the observed worst: 1.4e-8, the 3-node PPO agent; the unguarded
agent's terminal miss moved by 1.3e-5 m), not to the 1e-15 of a replay on the same machine.

The tolerances below are set from what a perturbation of that kind does, every action multiplied
by ``1 + u``, ``u`` uniform within +-4 float32 ulps, redrawn each call: the rate moves by at most
5e-8 relative (the multi-node generalist, over 8 suite scenarios) and the terminal miss by at most
6e-5 m. ``RATE_REL`` leaves a factor 20 over that, ``MISS_ABS`` a factor 33; both still hold
under +-64 ulps, sixteen times more noise (``python benchmarks/replay_tolerance.py`` prints these
numbers).

They still break on a real regression: an observation scaled by ``1 + 1e-3`` (a changed
normalisation) moves every shipped agent's rate by 3.6e-6 relative or more and the unguarded
agent's miss by 9e-3 m, 4.5 times ``MISS_ABS`` (``test_evaluate.py`` checks this for each
shipped agent); another checkpoint or a changed reward moves them by orders of magnitude more.
Two replays on the same machine are compared bit for bit elsewhere (seeded determinism, parity
tests).

## Planners re-run (``PLANNER_REL``)
The planners (DP, the tour, the DP bound, the hover heuristics) compute in float64 with no
float32 policy in the loop. Another CPU changes them only through its libm and SIMD paths (numpy's
AVX-512 transcendentals, numba's reassociated sums), ~1e-16 relative per operation and ~1e-15 on a
plan's rate, so ``PLANNER_REL`` leaves six orders of magnitude while any change of a planner's
grid, objective or tie-breaking moves a rate by far more. SCA (an interior-point solver stopped
at its own tolerance) is compared at ``SOLVER_REL``, the order of its stopping tolerance.
"""

from __future__ import annotations

#: Relative tolerance of a replayed episode's rate (bps/Hz) against its record.
RATE_REL = 1e-6
#: Absolute tolerance of a replayed episode's terminal miss |q[N] - qF| (m) against its record.
MISS_ABS = 2e-3
#: The observation scaling that stands for a changed normalisation in the test of the tolerances.
NORMALISATION_CHANGE = 1e-3
#: Relative tolerance of a float64 planner's re-run value against its stored reference.
PLANNER_REL = 1e-9
#: Relative tolerance of an SCA re-run (a conic solver's stopping tolerance) against its stored value.
SOLVER_REL = 1e-6
