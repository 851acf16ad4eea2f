"""Paddles-v1, superseded by Paddles-v2 (:mod:`phyplan_envs.tasks.paddles`) and kept registered and reproducible.

Frozen: this file changes only if the v1 outcomes would otherwise change. The versions differ only in the episode
cap: v1 ends every episode after 4 s, where from N = 8 on the ball may still be falling through the paddles (from
N = 9 on it mostly is); v2's cap grows with N beyond N = 6. Their outcomes are the same up to N = 6, and beyond
wherever v1's ball landed within 4 s.
"""
from __future__ import annotations

import warnings

from .. import assets
from .paddles import LANDS_IN_TIME, PaddlesEnv


class PaddlesEnvV1(PaddlesEnv):
    """``PhyPlan/Paddles-v1`` (``gym.make("PhyPlan/Paddles-v1", paddles=N)``): Paddles-v2
    (:class:`phyplan_envs.tasks.paddles.PaddlesEnv`: actions, scene, context, observation, reward, the Panda) with
    an episode cap of 4 s at every N. From N = 8 on the fall through the paddles can outlast it, and the episode
    then ends with the ball in the air (``info["end_reason"] == "timeout"``), rewarded where the ball is then
    (docs/depth.md, *Episode cap*); the env warns when it is built with N > 7.

    Version History:

    * v1: each placed paddle's offset from the one above; kept registered and reproducible, superseded by v2,
      whose episode cap grows with N.
    """

    max_sim_time = assets.MAX_SIM_TIME

    def __init__(self, paddles: int = 3, **kwargs):
        super().__init__(paddles, **kwargs)
        if self.paddles > LANDS_IN_TIME:
            warnings.warn(f"Paddles v0/v1 with paddles={self.paddles}: the ball falls for longer than their 4 s "
                          "episode cap on some actions (most from N = 9 on); those episodes end with it in the air "
                          "(info['end_reason'] == 'timeout'), rewarded where it is then; Paddles-v2's cap grows with "
                          "N (docs/depth.md)", stacklevel=2)
