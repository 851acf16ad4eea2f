"""SlideVaried-v0, BridgeVaried-v0, LaunchBounceVaried-v0 and PaddlesVaried-v0, superseded by the v1 ids
(:mod:`phyplan_envs.tasks.varied`: the block puck; LaunchBounceVaried's finer timestep; Paddles-v1's placement),
PaddlesVaried-v1, superseded by v2 (the episode cap grows with N), and PaddlesVaried-v2, superseded by v3 (exact
impacts), kept registered and reproducible. Frozen:
this file changes only if their outcomes would otherwise change."""
from __future__ import annotations

from ..hidden_physics import BridgeHidden, LaunchBounceHidden, PaddlesHidden, SlideHidden, varied
from .bridge_v0 import BridgeEnvV0
from .launch_bounce_v0 import LaunchBounceEnvV0
from .paddles_v0 import PaddlesEnvV0
from .paddles import PaddlesEnv
from .paddles_v1 import PaddlesEnvV1
from .slide import SlideEnv


class BridgeHiddenV0(BridgeHidden):
    """BridgeVaried-v0's hidden physics: v1's with the goals 0.9-1.4 m from the table centre."""

    goal_distance_range = (0.9, 1.4)


SlideVariedEnvV0 = varied("SlideVariedEnvV0", __name__, SlideEnv, SlideHidden, doc="""
    ``PhyPlan/SlideVaried-v0``: Slide with a hidden bob mass, bob-puck restitution and table friction.

    Actions (Slide-v0's):

    ``phi``    [0, pi/2]     rad: plane of the pendulum's swing (direction the puck is hit)
    ``theta``  [pi/4, pi/2]  rad: release angle of the pendulum from vertical

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.1, 0.3) U (1.0, 6.0] (log-uniform); ``restitution`` (bob-puck) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]; ``friction`` (puck-table) nominal 0.35, train [0.25, 0.45], test
    [0.15, 0.25) U (0.45, 0.6]. The test split draws from the test space, train and dev from the train space.
    The stopping distance depends on them through k^2 / mu (k: launch speed over bob speed) only.
    The puck starts on a 9 cm frictionless pad 0.5 mm above the table (the push happens on it).
    Goal: distance U(0.35, 1.65) m from the puck, direction U(0, pi/2), redrawn until reachable under the context's
    physics. State observation ``goal_x, goal_y, object_x, object_y, object_z, table_height`` (m), end rule (the
    puck stops, or 4 s pass) and reward ``1 - d/d0`` as Slide-v0 (:class:`phyplan_envs.tasks.slide.SlideEnv`).

    Version History:
        v0: first version (kept registered and reproducible; superseded by v1,
        :class:`phyplan_envs.tasks.varied.SlideVariedEnv`).
        v1: the puck is a square block turned to the swing plane, on a square pad; slow friction reference.
    """)


BridgeVariedEnvV0 = varied("BridgeVariedEnvV0", __name__, BridgeEnvV0, BridgeHiddenV0, doc="""
    ``PhyPlan/BridgeVaried-v0``: Bridge with a hidden bob mass, bob-puck restitution and table/plank friction.

    Actions (Bridge's):

    ``phi``         [0, pi/2]     rad: plane of the pendulum's swing (direction the puck is hit, from +x)
    ``theta``       [pi/4, pi/2]  rad: release angle of the pendulum from vertical
    ``bridge_yaw``  [0, pi/2]     rad: direction of the bridge plank from the table centre (from +x)

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.1, 0.3) U (1.0, 6.0] (log-uniform); ``restitution`` (bob-puck) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]; ``friction`` (puck on the table top and on the plank, one value) nominal 0.35,
    train [0.25, 0.45], test [0.15, 0.25) U (0.45, 0.6]. The test split draws from the test space, train and dev
    from the train space. The puck starts on a 9 cm frictionless pad 0.5 mm above the table.
    Goal: distance U(0.9, 1.4) m from the table centre, direction U(0, pi/2), redrawn until reachable under the
    context's physics (high friction with a slow puck leaves only the nearer goals). State observation ``goal_x,
    goal_y, object_x, object_y, object_z, table_radius, table_height, bridge_length, bridge_width`` (m), plank, end
    rule and reward as Bridge-v0 (:class:`phyplan_envs.tasks.bridge_v0.BridgeEnvV0`).

    Version History:
        v0: first version (kept registered and reproducible; superseded by v1,
        :class:`phyplan_envs.tasks.varied.BridgeVariedEnv`).
        v1: the puck is a square block turned to the swing plane, on a square pad; the round table top collides as
        a square turned with it; slow friction reference.
    """)


LaunchBounceVariedEnvV0 = varied("LaunchBounceVariedEnvV0", __name__, LaunchBounceEnvV0, LaunchBounceHidden, doc="""
    ``PhyPlan/LaunchBounceVaried-v0``: LaunchBounce with a hidden bob mass, bob-ball restitution and ball-wedge
    restitution.

    Actions (LaunchBounce-v0's):

    ``phi``             [0, pi/2]     rad: plane of the pendulum's swing (direction the ball is hit)
    ``theta``           [pi/4, pi/2]  rad: release angle of the pendulum from vertical
    ``wedge_distance``  [0.2, 1.0]    m: distance of the wedge's axis from the pedestal
    ``wedge_angle``     [0, pi/2]     rad: direction of the wedge's axis from the pedestal (from +x)
    ``wedge_yaw``       [-pi, pi]     rad: yaw of the wedge (its incline falls towards it)

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.1, 0.3) U (1.0, 6.0] (log-uniform); ``restitution`` (bob-ball) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]; ``wedge_restitution`` (ball-wedge) nominal 0.8, train [0.7, 0.9], test
    [0.4, 0.7) U (0.9, 0.99]. The test split draws from the test space, train and dev from the train space.
    Goal: LaunchBounce-v0's sampler (0.3-0.6 m from the ball, direction U(pi, 2 pi)), redrawn until its distance is
    inside the context's reach band (LaunchBounce-v0's farthest landing behind, 0.9 m at its restitution 0.949,
    scaled by the squared launch speed and the squared ball-wedge restitution,
    :class:`phyplan_envs.hidden_physics.LaunchBounceHidden`). State observation ``goal_x, goal_y, object_x,
    object_y, object_z, pivot_height`` (m), end rule and reward as LaunchBounce-v0
    (:class:`phyplan_envs.tasks.launch_bounce.LaunchBounceEnv`).

    At this timestep the landings of bouncing actions have not converged in the timestep (docs/composition.md,
    *Certificates*); v1 steps at 0.0625 ms.

    Version History:
        v0: first version (kept registered and reproducible; superseded by v1,
        :class:`phyplan_envs.tasks.varied.LaunchBounceVariedEnv`, whose timestep is 0.0625 ms).
    """)


PaddlesVariedEnvV0 = varied("PaddlesVariedEnvV0", __name__, PaddlesEnvV0, PaddlesHidden, doc="""
    ``PhyPlan/PaddlesVaried-v0`` (``gym.make(..., paddles=N)``): Paddles-N with a hidden ball-paddle restitution.

    Actions (Paddles-v0's; N = 3 shown, with N paddles ``paddle1_x`` .. ``paddle<N-1>_x``):

    ``theta``      [0.2, 0.5]  rad: release angle of the pendulum from vertical
    ``paddle1_x``  [-1, 1]     m: x of paddle 1's centre (paddle 0 is fixed at x = 0.25)
    ``paddle2_x``  [-1, 1]     m: x of paddle 2's centre

    Hidden parameter (:mod:`phyplan_envs.hidden_physics`): ``paddle_restitution`` (all paddles, an impact pair each)
    nominal 0.1, train [0.05, 0.25], test [0.02, 0.05) U (0.25, 0.4]. With restitution the ball hops along a
    paddle instead of gliding down it (Paddles-v0's paddles keep none of the normal speed), so where it leaves the
    paddle, and whether it touches it again, depend on it. Goal: Paddles-v0's sampler (not redrawn under the
    physics). State observation (float32, m) ``goal_x, goal_y, object_x, object_y, object_z, shelf_top,
    first_paddle_x``, end rule and reward as Paddles-v0 (:class:`phyplan_envs.tasks.paddles_v0.PaddlesEnvV0`).

    Version History:
        v0: first version (kept registered and reproducible; superseded by v1,
        :class:`phyplan_envs.tasks.varied.PaddlesVariedEnv`, on Paddles-v1).
    """)


PaddlesVariedEnvV1 = varied("PaddlesVariedEnvV1", __name__, PaddlesEnvV1, PaddlesHidden, doc="""
    ``PhyPlan/PaddlesVaried-v1`` (``gym.make(..., paddles=N)``): PaddlesVaried-v2
    (:class:`phyplan_envs.tasks.varied.PaddlesVariedEnv`: the hidden ball-paddle restitution, its spaces and the
    goals) on Paddles-v1 (:class:`phyplan_envs.tasks.paddles_v1.PaddlesEnvV1`): the episode cap is 4 s at every N,
    which from N = 8 on can end a fall in the air.

    Actions (Paddles-v1's; N = 3 shown, with N paddles ``paddle1_offset`` .. ``paddle<N-1>_offset``):

    ``theta``           [0.2, 0.5]  rad: release angle of the pendulum from vertical
    ``paddle1_offset``  [0.45, 0.9] m: paddle 1's x less paddle 0's (fixed at x = 0.25), along the ball's way
    ``paddle2_offset``  [0.45, 0.9] m: paddle 2's x less paddle 1's, along the ball's way

    State observation (float32, m) ``goal_x, goal_y, object_x, object_y, object_z, shelf_top, first_paddle_x``.

    Version History:
        v1: on Paddles-v1; kept registered and reproducible, superseded by v2 (the episode cap grows with N).
    """)


PaddlesVariedEnvV2 = varied("PaddlesVariedEnvV2", __name__, PaddlesEnv, PaddlesHidden, doc="""
    ``PhyPlan/PaddlesVaried-v2`` (``gym.make(..., paddles=N)``): Paddles-N with a hidden ball-paddle restitution.

    Actions (Paddles-v2's; N = 3 shown, with N paddles ``paddle1_offset`` .. ``paddle<N-1>_offset``):

    ``theta``           [0.2, 0.5]  rad: release angle of the pendulum from vertical
    ``paddle1_offset``  [0.45, 0.9] m: paddle 1's x less paddle 0's (fixed at x = 0.25), along the ball's way
    ``paddle2_offset``  [0.45, 0.9] m: paddle 2's x less paddle 1's, along the ball's way

    Hidden parameter (:mod:`phyplan_envs.hidden_physics`): ``paddle_restitution`` (all paddles, an impact pair each)
    nominal 0.1, train [0.05, 0.25], test [0.02, 0.05) U (0.25, 0.4]. With restitution the ball hops along a
    paddle instead of gliding down it (Paddles' paddles keep none of the normal speed), so where it leaves the
    paddle, and whether it touches it again, depend on it. Goal: Paddles-v2's sampler (not redrawn under the
    physics). State observation (float32, m) ``goal_x, goal_y, object_x, object_y, object_z, shelf_top,
    first_paddle_x``, end rule (with its episode cap growing with N beyond N = 6) and reward as Paddles-v2
    (:class:`phyplan_envs.tasks.paddles.PaddlesEnv`).

    Not converged in the timestep, nor stable: the impact pair's rebound depends on where in a 0.5 ms step the ball
    arrives, every hop carries that on, and the landings move by centimetres when the timestep halves or the action
    moves by 1e-4, at every N and at timesteps down to 0.0625 ms
    (``python -m benchmarks.design_checks.paddles --chaos 30 --depths 1 2 3 --physics-space train --halvings H``;
    docs/depth.md, *Hidden physics*).

    Version History:
        v0: first version, on Paddles-v0 (kept registered and reproducible:
        :class:`phyplan_envs.tasks.varied_v0.PaddlesVariedEnvV0`).
        v1: on Paddles-v1 (each placed paddle's offset from the one above; v1's goal ranges; kept registered and
        reproducible: :class:`phyplan_envs.tasks.varied_v0.PaddlesVariedEnvV1`).
        v2: on Paddles-v2 (the episode cap grows with N beyond N = 6; v1's outcomes up to N = 6); kept registered
        and reproducible, superseded by v3 (:class:`phyplan_envs.tasks.varied.PaddlesVariedEnv`: exact impacts).
    """)
