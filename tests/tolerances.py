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

## Golden episodes re-run (``GOLDEN_REL``, ``GOLDEN_OBS_ABS``)

A golden episode (``tests/envs/golden/``) is re-run with the same seeded actions, so no float32
policy is in the loop, but its numbers still move with the CPU: numba's kernels are compiled for
the host with fast-math (reassociated node sums, fused multiply-add where the CPU has it) and
numpy's transcendentals take SIMD paths, ~1e-16 relative per operation. The arrival guard then
amplifies that: once the UAV has no spare move left, its projection onto the two disks takes a
square root of a difference that is 0 in exact arithmetic, so an eps-level rounding becomes a
sqrt(eps) D ~ 1e-7 m change of position, which every later rate, reward and observation carries.
Measured (the compiled kernels against the plain-Python ones, ``IOS_UAV_ENV_NO_NUMBA=1``, and
every action multiplied by ``1 + u``, ``|u|`` up to 1e-14, on every id): a float64 value moves
by at most 9e-9 of its key's largest magnitude (a multi-node reward, a difference of running
minima), so ``GOLDEN_REL`` leaves a factor 100. The observations are float32 features scaled
to O(1); most move by a float32 ulp (~1e-7), but the measured (faded) rates of the reported-node
ids depend on the carrier phase, 2 pi / lambda per metre of distance, and move by up to 1.3e-5:
``GOLDEN_OBS_ABS`` leaves a factor 15. A real regression still breaks both: the noise power
changed by 0.01 dB moves the rates by ~1e-3 relative (2e-3 bps/Hz, in the info and in the rate
feature), and a dropped or changed normalisation moves a feature by far more than 2e-4.

## A batch against its single envs: measured rates (``BATCH_MEASURED_REL``)

A batched env and its rows' single envs run on the same machine and are compared bit for bit,
except where a number comes out of the node rates of the step: the batch computes them in its
parallel kernel, the single env in the serial one, and the fast-math node sums of the two
compilations round differently in the last bits (the rewards are compared to 1e-9 for this
reason). A multi-node row's measured rate is the faded sample of its node's expected-gain rate
of the step (``channel.faded_of_rate``), and its served tally sums those, so both inherit that
rounding: a few ulps of a rate, amplified at most by r ln 2 (r < 20 bps/Hz) in 2^r - 1, ~1e-14
relative. ``BATCH_MEASURED_REL`` leaves a factor 100. A real regression (another slot's kernel,
another node's normals, a lost clip) moves a measured rate by far more than 1e-6.

## A moving-node agent replayed (``MOBILE_REPLAY_REL``)

The moving-node agent (``ppo_IOSUAV-Mobile-v0``) observes the *measured* rates of the slots flown,
and a measured (faded) rate depends on the carrier phase of the path length, which turns a change
of 1e-7 m in a way-point into a change of ~1e-5 in a feature. Its closed loop therefore amplifies
a float32 ulp of an action to a different flight: actions multiplied by ``1 + u``, ``u`` within
+-1 float32 ulp, move the seed-0 episode's average rate by up to 1.3 % relative, within +-4 ulps
by up to 2.1 % (the recorded 0.48510 bps/Hz replays as 0.48197 on a machine other than the one
that recorded it, 0.65 % off). ``RATE_REL`` cannot hold for it there; ``MOBILE_REPLAY_REL``
leaves a factor 2.4 over the +-4 ulps figure. What still pins the agent: two replays on the same
machine are equal bit for bit, and its suite score must stay above MPC(k=1) on every run.

## The multi-node agent with memory on its suite (``MULTI_MOBILE_MEAN_ABS``)

The multi-node moving agent (``ppo_memory_IOSUAV-MultiNode-Mobile-v0``) also observes measured
(faded) rates, and its closed loop decides whom to serve and where to fly from them, so a float32
ulp of an action can send it to another node: actions multiplied by ``1 + u``, ``u`` within +-4
float32 ulps, move one scenario's rate by up to 18 % (the first 4 scenarios, 4 draws: no
per-episode tolerance is useful), and the mean % of the optimum over the 24 scenarios of
``multi-node-mobile-v1`` by up to 2.50 points (6 draws; 1.84 under +-64 ulps;
``python benchmarks/replay_tolerance.py --multi-node-mobile`` prints them).
``MULTI_MOBILE_MEAN_ABS`` leaves a factor 2.4 over that. It does not tell two nearby checkpoints
of the recipe apart (they score within a few points of each other); a changed normalisation it
does catch (every observation scaled by 1 + 1e-3 moves the mean by 61 points), and two replays
on the same machine are equal bit for bit.
"""

from __future__ import annotations

#: Relative tolerance of a replayed episode's rate (bps/Hz) against its record.
RATE_REL = 1e-6
#: Relative tolerance of the moving-node agent's replayed rate against its record (see above).
MOBILE_REPLAY_REL = 0.05
#: Absolute tolerance of a replayed episode's terminal miss |q[N] - qF| (m) against its record.
MISS_ABS = 2e-3
#: The observation scaling that stands for a changed normalisation in the test of the tolerances.
NORMALISATION_CHANGE = 1e-3
#: Relative tolerance of a float64 planner's re-run value against its stored reference.
PLANNER_REL = 1e-9
#: Relative tolerance of an SCA re-run (a conic solver's stopping tolerance) against its stored value.
SOLVER_REL = 1e-6
#: Relative tolerance of a batched multi-node row's measured rates and served tally against its
#: single env's (the step's node rates round differently in the parallel and the serial kernel).
BATCH_MEASURED_REL = 1e-12
#: Largest change of a golden episode's float64 value (info, reward), in units of max(1, the
#: largest magnitude of the same key in the recorded episode).
GOLDEN_REL = 1e-6
#: Largest absolute change of a golden episode's float32 observation feature, on the ids that
#: observe measured (faded) rates (their carrier phase turns 1e-7 m into ~1e-5).
GOLDEN_OBS_ABS = 2e-4
#: The same on every other id: their features move by a float32 ulp (~1e-7 on O(1) features), so
#: 1e-5 leaves a factor 100 and a changed normalisation of a small feature still shows.
GOLDEN_EXACT_OBS_ABS = 1e-5
#: Points of mean % of the clairvoyant optimum of the multi-node agent with memory over
#: multi-node-mobile-v1 against its record (see above).
MULTI_MOBILE_MEAN_ABS = 6.0
