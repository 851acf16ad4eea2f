"""Paddles-v0, superseded by Paddles-v1 (:mod:`phyplan_envs.tasks.paddles_v1`) and kept registered and reproducible.

Frozen: this file changes only if the v0 outcomes would otherwise change. The versions differ in how the paddles are
placed (v0: each placed paddle's absolute x; v1: its offset from the paddle above) and in the goal ranges; the
scene, its facts, the reward and the 4 s episode cap are v1's.
"""
from __future__ import annotations

import numpy as np

from .paddles import GOAL_NEAREST, PaddlesEnv

PADDLE_SPAN = (-1.0, 1.0)     # m: the placed paddles' x (the original code's)
# The goals' x ranges per N (m): the p5-p95 of the landings of v0's chain actions (actions whose ball meets every
# paddle), python -m benchmarks.design_checks.paddles --reach 40 --version 0, and at least GOAL_NEAREST.
GOAL_RANGE_V0 = {1: (1.406, 1.414), 2: (0.438, 0.910), 3: (0.897, 1.526), 4: (GOAL_NEAREST, 1.071),
                 5: (0.700, 1.559), 6: (GOAL_NEAREST, 1.249)}


class PaddlesEnvV0(PaddlesEnv):
    """``PhyPlan/Paddles-v0`` (``gym.make("PhyPlan/Paddles-v0", paddles=N)``, N >= 1, default 3): push a ball off a
    high shelf with the pendulum so that it falls through N tilted paddles, whose positions you set, into a goal on
    the floor.

    ==============  ==========  ====  ==========================================================================
    action          bounds      unit  meaning
    ==============  ==========  ====  ==========================================================================
    ``theta``       [0.2, 0.5]  rad   release angle of the pendulum from vertical (it swings along +x)
    ``paddle1_x``   [-1, 1]     m     x of paddle 1's centre (paddle 0 is fixed at x = 0.25)
    ``paddle2_x``   [-1, 1]     m     x of paddle 2's centre
    ==============  ==========  ====  ==========================================================================

    The table is N = 3's; with N paddles the actions are ``theta`` and ``paddle1_x`` .. ``paddle<N-1>_x``, each in
    [-1, 1] m (N = 1: ``theta`` alone).

    Scene: v1's (the original code's ``paddles``: a shelf at ``N + 1.5`` m, N paddles 0.5 m square tilted 45 degrees
    alternately, the i-th at ``N + 1.0 - i`` m), the placed paddles resting between attempts at the end of [-1, 1] m
    away from the way their face falls.

    Context: the goal on the line y = 0 ahead of the shelf, x uniform in a per-N range (:data:`GOAL_RANGE_V0`:
    where the chains that meet every paddle land, p5-p95; docs/depth.md, *Paddles-v0*). State observation (float32,
    m): ``goal_x, goal_y, object_x, object_y, object_z, shelf_top, first_paddle_x``. Episode end, reward, timestep,
    physical facts and the Panda: as v1's (:class:`phyplan_envs.tasks.paddles_v1.PaddlesEnvV1`, 4 s cap).
    Certificates: ``python -m benchmarks.design_checks.paddles --version 0``.

    Version History:

    * v0: first release (the original code's unfinished ``paddles``, with a bounce model and any N); kept
      registered and reproducible, superseded by v1 (:class:`phyplan_envs.tasks.paddles_v1.PaddlesEnvV1`), which
      places each paddle relative to the one above.
    """

    goal_ranges = GOAL_RANGE_V0
    cap_per_paddle = 0.0               # v1's 4 s episode cap at every N

    def _placing_tools(self) -> list:
        """Paddle 0 at its fixed x; each placed paddle its own action dimension ``paddle<i>_x`` in
        :data:`PADDLE_SPAN`, resting at the span's end away from the way its face falls."""
        placed = [self._paddle(0, x=self.facts.first_paddle_x)]
        for i, falls in enumerate(self.facts.paddle_falls[1:], start=1):
            placed.append(self._paddle(i, span=PADDLE_SPAN,
                                       rest_x=PADDLE_SPAN[1] if falls < 0 else PADDLE_SPAN[0]))
        return placed

    def paddle_x(self, actions) -> np.ndarray:
        """The paddles' x (K, N) for the actions ``actions`` (K, action_dim, or one action)."""
        a = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        return np.column_stack([np.full(len(a), self.facts.first_paddle_x), a[:, 1:]])
