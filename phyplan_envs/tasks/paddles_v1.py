"""Paddles-v1, superseded by Paddles-v2 (:mod:`phyplan_envs.tasks.paddles`) and kept registered and reproducible.

Frozen: this file changes only if the v1 outcomes would otherwise change. The versions differ only in the episode
cap: v1 ends every episode after 4 s, where from N = 8 on the ball may still be falling through the paddles (from
N = 9 on it mostly is); v2's cap grows with N beyond N = 6. Their outcomes are the same up to N = 6, and beyond
wherever v1's ball landed within 4 s.
"""
from __future__ import annotations

from .paddles import PaddlesEnv


class PaddlesEnvV1(PaddlesEnv):
    """``PhyPlan/Paddles-v1`` (``gym.make("PhyPlan/Paddles-v1", paddles=N)``, N >= 1, default 3): Paddles-v2
    (:class:`phyplan_envs.tasks.paddles.PaddlesEnv`: scene, context, reward, the Panda) with an episode cap of 4 s
    at every N.

    ==================  ===========  ====  =====================================================================
    action              bounds       unit  meaning
    ==================  ===========  ====  =====================================================================
    ``theta``           [0.2, 0.5]   rad   release angle of the pendulum from vertical (it swings along +x)
    ``paddle1_offset``  [0.45, 0.9]  m     paddle 1's x less paddle 0's (fixed at x = 0.25), along the way the
                                           ball leaves paddle 0
    ``paddle2_offset``  [0.45, 0.9]  m     paddle 2's x less paddle 1's, along the way the ball leaves paddle 1
    ==================  ===========  ====  =====================================================================

    The table is N = 3's; with N paddles the actions are ``theta`` and ``paddle1_offset`` .. ``paddle<N-1>_offset``.
    State observation (float32, m): ``goal_x, goal_y, object_x, object_y, object_z, shelf_top, first_paddle_x``.
    Episode end: the ball lands, rests, or 4 s pass. From N = 8 on the fall through the paddles can outlast that
    cap, and the episode then ends with the ball in the air (``info["end_reason"] == "timeout"``), rewarded where
    the ball is then (docs/depth.md, *Episode cap*); the env warns when it is built with N > 7.

    Version History:

    * v1: each placed paddle's offset from the one above; kept registered and reproducible, superseded by v2,
      whose episode cap grows with N.
    """

    cap_per_paddle = 0.0
