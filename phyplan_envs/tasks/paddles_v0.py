"""Paddles-v0, superseded by Paddles-v1 (:mod:`phyplan_envs.tasks.paddles`) and kept registered and reproducible.

Frozen: this file changes only if the v0 outcomes would otherwise change. The versions differ in how the paddles are
placed (v0: each placed paddle's absolute x; v1: its offset from the paddle above) and in the goal ranges; the
scene, its facts and the reward are :mod:`phyplan_envs.tasks.paddles`'s.
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

    Scene (the original code's ``paddles``): a frictionless floating shelf with its top at ``N + 1.5`` m and its
    front edge at x = 0, where Launch's ball rests; Launch's pendulum behind it, swinging in the xz plane. N paddles,
    0.5 m square boards (0.02 m thick) tilted 45 degrees alternately, the last one's face falling towards +x,
    frictionless and overdamped (they keep none of the ball's normal speed), the i-th (from 0) with its face centre
    at ``N + 1.0 - i`` m. Pushed off the shelf, the ball meets paddle 0, glides down it (its speed along the face
    kept), leaves its lower edge, meets paddle 1 if it is placed under that flight, and so
    on; from the last paddle it falls to the floor. The chain: swing, hit, then (throw, bounce, glide) per paddle,
    then the last throw.

    State observation (float32, m): ``goal_x, goal_y, object_x, object_y, object_z, shelf_top, first_paddle_x``.
    Context: the goal on the line y = 0 ahead of the shelf, x uniform in a per-N range (:data:`GOAL_RANGE_V0`:
    where the chains that meet every paddle land, p5-p95; docs/depth.md).
    Episode end: the ball's centre falls below ``BALL_RADIUS + 0.01`` m (it lands; xy interpolated at the
    crossing), the ball rests, or ``MAX_SIM_TIME`` passes.
    Reward: ``1 - d/d0``, d the landing point's xy distance from the goal centre, d0 the ball's at reset.
    Timestep 0.5 ms (the end rule every 5 ms). Physical facts: :attr:`facts`, a :class:`PaddlesFacts`.
    Certificates (docs/depth.md): ``python -m benchmarks.design_checks.paddles`` (solvable, every
    paddle matters, converged, not chaotic, per N).

    The Panda stands on a stand beside the shelf (its base 0.45 m behind the ball and 0.33 m below it, as in
    LaunchBounce); in robot mode it swings the pendulum and the scene places the paddles.

    Version History:

    * v0: first release (the original code's unfinished ``paddles``, with a bounce model and any N); kept
      registered and reproducible, superseded by v1 (:class:`phyplan_envs.tasks.paddles.PaddlesEnv`), which places
      each paddle relative to the one above.
    """

    goal_ranges = GOAL_RANGE_V0

    def _placing_tools(self) -> list:
        """Paddle 0 at its fixed x; each placed paddle its own action dimension ``paddle<i>_x`` in
        :data:`PADDLE_SPAN`, resting at the span's end away from the way its face falls."""
        self.placed = [self._paddle(0, x=self.facts.first_paddle_x)]
        for i, falls in enumerate(self.facts.paddle_falls[1:], start=1):
            self.placed.append(self._paddle(i, span=PADDLE_SPAN,
                                            rest_x=PADDLE_SPAN[1] if falls < 0 else PADDLE_SPAN[0]))
        return self.placed

    def paddle_x(self, actions) -> np.ndarray:
        """The paddles' x (K, N) for the actions ``actions`` (K, action_dim, or one action)."""
        a = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        return np.column_stack([np.full(len(a), self.facts.first_paddle_x), a[:, 1:]])
