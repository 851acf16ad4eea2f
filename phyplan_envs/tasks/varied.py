"""The varied tasks: each is its nominal task's assembly plus a hidden-physics component (``hidden_model``,
:mod:`phyplan_envs.hidden_physics`) that draws per-context physics the agent must discover.

``PhyPlan/LaunchVaried-v0``, ``SlideVaried-v1``, ``BounceVaried-v0``, ``BridgeVaried-v1`` and
``LaunchBounceVaried-v1`` and ``PaddlesVaried-v3`` (the superseded ``SlideVaried-v0``, ``BridgeVaried-v0``,
``LaunchBounceVaried-v0``, ``PaddlesVaried-v0``, ``-v1`` and ``-v2``: :mod:`phyplan_envs.tasks.varied_v0`) keep the
action space, observation, end rule and reward of their nominal task. What differs (all documented per class):

* hidden parameters drawn per context from the train or test space (:data:`phyplan_envs.hidden_physics.PARAMETERS`);
  they are in neither the observation, ``info`` nor the context (which holds a ``physics_token``, the context's
  physics sealed under a secret of the process: :class:`phyplan_envs.hidden_physics.HiddenPhysics`); the privileged
  ``env.hidden_physics`` returns them;
* the goal is drawn after the physics and redrawn until it is reachable under it (a closed-form reach band of the
  task, the component's ``reach_band``, shrunk by ``REACH_MARGIN``); if the band misses the goal region the physics
  is redrawn. The goal therefore carries some information about the physics (a far goal means a "fast" context);
* timestep 0.5 ms (LaunchBounceVaried-v1: 0.0625 ms, its ball meets the wedge mid-flight), and the attempt starts
  at the first touch: the ball's free fall onto the incline (Bounce) and the pendulum's frictionless swing (the
  others) are integrated in closed form and the simulation starts with the bodies exactly touching at the
  energy-conserving speed, so the contact's start does not depend on where it falls between two time steps (the
  nominal tasks' sawtooth); ``info["sim_time"]`` counts the simulated part only;
* the bob collides through a sphere (its own body, mass per context); the puck starts on a 0.5 mm frictionless pad.
"""
from __future__ import annotations

from ..hidden_physics import (BounceHidden, BridgeHidden, LaunchBounceHidden, LaunchHidden, PaddlesImpactHidden,
                              SlideHidden, varied)
from .bounce import BounceEnv
from .bridge import BridgeEnv
from .launch import LaunchEnv
from .launch_bounce import LaunchBounceEnv
from .paddles import PaddlesEnv
from .slide import SlideEnv

LAUNCH_BOUNCE_TIMESTEP = 0.0000625   # s: LaunchBounceVaried-v1's (its docstring says why)

__all__ = ["BounceVariedEnv", "BridgeVariedEnv", "LaunchBounceVariedEnv", "LaunchVariedEnv", "PaddlesVariedEnv",
           "SlideVariedEnv"]


# ================================================================================================== the envs
LaunchVariedEnv = varied("LaunchVariedEnv", __name__, LaunchEnv, LaunchHidden, doc="""
    ``PhyPlan/LaunchVaried-v0``: Launch with a hidden bob mass and bob-ball restitution.

    Actions (Launch-v0's):

    ``phi``    [0, pi/2]     rad: plane of the pendulum's swing (direction the ball is hit, from +x)
    ``theta``  [pi/4, pi/2]  rad: release angle of the pendulum from vertical

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.05, 0.3) U (1.0, 3.0] (log-uniform); ``restitution`` (bob-ball) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]. The test split draws from the test space, train and dev from the train space.
    Only their combination k ~ (1 + e) m/(m + m_ball) (the launch speed over the bob speed) shows in a landing.
    Goal: distance U(0.3, 1.0) m from the ball, direction U(0, pi/2), redrawn until reachable under the context's
    physics (see :mod:`phyplan_envs.tasks.varied`). State observation ``goal_x, goal_y, object_x, object_y,
    object_z, pivot_height`` (m), end rule (the ball lands, rests, or 4 s pass) and reward ``1 - d/d0`` as Launch-v0
    (:class:`phyplan_envs.tasks.launch.LaunchEnv`).

    Version History:
        v0: first version.
    """)


SlideVariedEnv = varied("SlideVariedEnv", __name__, SlideEnv, SlideHidden, puck_shape="block", doc="""
    ``PhyPlan/SlideVaried-v1``: Slide with a hidden bob mass, bob-puck restitution and table friction, the puck a
    square block facing the swing plane.

    Actions (Slide-v0's):

    ``phi``    [0, pi/2]     rad: plane of the pendulum's swing (direction the puck is hit)
    ``theta``  [pi/4, pi/2]  rad: release angle of the pendulum from vertical

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.1, 0.3) U (1.0, 6.0] (log-uniform); ``restitution`` (bob-puck) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]; ``friction`` (puck-table) nominal 0.35, train [0.25, 0.45], test
    [0.15, 0.25) U (0.45, 0.6]. The test split draws from the test space, train and dev from the train space.
    The stopping distance depends on them through k^2 / mu (k: launch speed over bob speed) only.
    Goal: distance U(0.35, 1.65) m from the puck, direction U(0, pi/2), redrawn until reachable under the context's
    physics. State observation ``goal_x, goal_y, object_x, object_y, object_z, table_height`` (m), end rule (the
    puck stops, or 4 s pass) and reward ``1 - d/d0`` as Slide-v0 (:class:`phyplan_envs.tasks.slide.SlideEnv`).

    The puck is a square block of the disc's footprint area (half edge 17.7 mm, same mass and thickness,
    :func:`phyplan_envs.block.make_block`), on a square frictionless pad of half edge 4.5 cm, 0.5 mm above the table
    (the push happens on it); before each attempt both are turned to the swing plane ``phi`` (the bob hits the middle
    of a face; the block leaves the pad 4.5 cm along its path). In robot mode the scene turns them, not the arm. The
    friction pair has a slow friction reference (``solreffriction`` (0.05, 1)): the sliding block's hops are
    sub-millimetre instead of millimetres. So the outcome converges in the timestep (v0 and v1 measured by ``python
    -m benchmarks.design_checks.hidden_physics --only convergence [--version 0]``; figures in docs/hidden-physics.md).

    Version History:
        v0: first version (:class:`phyplan_envs.tasks.varied_v0.SlideVariedEnvV0`: the disc on a round pad).
        v1: the block (above).
    """)


BridgeVariedEnv = varied("BridgeVariedEnv", __name__, BridgeEnv, BridgeHidden, doc="""
    ``PhyPlan/BridgeVaried-v1``: Bridge with a hidden bob mass, bob-puck restitution and table/plank friction,
    the puck a square block facing the swing plane.

    Actions (Bridge's):

    ``phi``         [0, pi/2]     rad: plane of the pendulum's swing (direction the puck is hit, from +x)
    ``theta``       [pi/4, pi/2]  rad: release angle of the pendulum from vertical
    ``bridge_yaw``  [0, pi/2]     rad: direction of the bridge plank from the table centre (from +x)

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.1, 0.3) U (1.0, 6.0] (log-uniform); ``restitution`` (bob-puck) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]; ``friction`` (puck on the table top and on the plank, one value) nominal 0.35,
    train [0.25, 0.45], test [0.15, 0.25) U (0.45, 0.6]. The test split draws from the test space, train and dev
    from the train space. State observation ``goal_x, goal_y, object_x, object_y, object_z, table_radius,
    table_height, bridge_length, bridge_width`` (m), plank, end rule and reward as Bridge-v1
    (:class:`phyplan_envs.tasks.bridge.BridgeEnv`).

    Goals at distance U(0.6, 1.4) m from the table centre, direction U(0, pi/2), redrawn until reachable under the
    context's physics (high friction with a slow puck leaves only the nearer goals): the goals short of the plank's
    end (1.0 m) are stops on the plank (their marker lies on the floor below it), as friction-sensitive as Slide's.
    With v0's goals (0.9-1.4 m) a planner that ignores the hidden physics (the oracle's search on the nominal
    simulator) kept a regret below the 0.10 that makes the track test adaptation; with these it does not (``python -m
    benchmarks.design_checks.hidden_physics --only nominal --tasks bridge [--version 0]``; figures in
    docs/hidden-physics.md).

    The puck is Bridge-v1's block, on a square frictionless pad of half edge 4.5 cm, 0.5 mm above the table; before
    each attempt both are turned to the swing plane ``phi`` with the table's square collider (in robot mode by the
    scene, not the arm); its friction pairs have a slow friction reference (sub-millimetre hops), so the outcome
    converges in the timestep (``python -m benchmarks.design_checks.hidden_physics --only convergence [--version
    0]``; figures in docs/hidden-physics.md).

    Version History:
        v0: first version (:class:`phyplan_envs.tasks.varied_v0.BridgeVariedEnvV0`: the disc, goals 0.9-1.4 m).
        v1: the block, the square table-top collider and the wider goal range (above).
    """)


BounceVariedEnv = varied("BounceVariedEnv", __name__, BounceEnv, BounceHidden, doc="""
    ``PhyPlan/BounceVaried-v0``: Bounce with a hidden ball-incline restitution.

    Actions (Bounce-v0's):

    ``wedge_yaw``    [-pi, pi]   rad: yaw of the wedge about its vertical axis (the ball flies off along it, from +x)
    ``drop_height``  [0.5, 1.5]  m: height of the ball's centre above the ground at release

    Hidden parameter (:mod:`phyplan_envs.hidden_physics`): ``restitution`` (ball-incline) nominal 0.8, train
    [0.7, 0.9], test [0.4, 0.7) U (0.9, 0.99]. The test split draws from the test space, train and dev from the
    train space. A lower restitution sends the ball off slower and downwards: at e = 0.5 the landing range is
    0.36-0.59 m, at 0.8 0.39-0.87 m, at 0.98 0.44-1.1 m (drop heights 0.5-1.5 m).
    The wedge's round stand has radius 0.15 m (Bounce-v0: 0.22 m), so that a slow, low ball clears it.
    Goal: the Bounce-v0 sampler, redrawn until its distance from the wedge axis is reachable under the context's
    restitution. State observation ``goal_x, goal_y, object_x, object_y, object_z, wedge_x, wedge_y, impact_z``
    (m), end rule and reward as Bounce-v0 (:class:`phyplan_envs.tasks.bounce.BounceEnv`).

    Version History:
        v0: first version.
    """)


LaunchBounceVariedEnv = varied("LaunchBounceVariedEnv", __name__, LaunchBounceEnv, LaunchBounceHidden, doc="""
    ``PhyPlan/LaunchBounceVaried-v1``: LaunchBounce with a hidden bob mass, bob-ball restitution and ball-wedge
    restitution.

    Actions (LaunchBounce-v1's):

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
    object_y, object_z, pivot_height`` (m), end rule and reward as LaunchBounce-v1
    (:class:`phyplan_envs.tasks.launch_bounce.LaunchBounceEnv`).

    Timestep 0.0625 ms (the end rule every 5 ms). The ball meets the wedge mid-flight, so that contact starts
    anywhere between two time steps, and the ball-wedge impact pair's damping (restitution below ~0.9) turns that
    phase into a different bounce: at 0.5 ms the landings of bouncing actions moved by centimetres when the timestep
    halved. At this step they converge for every restitution of the test space
    (``python -m benchmarks.design_checks.launch_bounce --chaos --varied``; docs/composition.md, *Certificates*).

    Version History:
        v0: first version, timestep 0.5 ms (kept registered and reproducible:
        :class:`phyplan_envs.tasks.varied_v0.LaunchBounceVariedEnvV0`).
        v1: timestep 0.0625 ms, so that bouncing landings converge in the timestep (the scene, actions, hidden
        physics, context and reward are v0's).
    """, timestep=LAUNCH_BOUNCE_TIMESTEP)


PaddlesVariedEnv = varied("PaddlesVariedEnv", __name__, PaddlesEnv, PaddlesImpactHidden, doc="""
    ``PhyPlan/PaddlesVaried-v3`` (``gym.make(..., paddles=N)``): Paddles-N with a hidden ball-paddle restitution.

    Actions (Paddles-v2's; N = 3 shown, with N paddles ``paddle1_offset`` .. ``paddle<N-1>_offset``):

    ``theta``           [0.2, 0.5]  rad: release angle of the pendulum from vertical
    ``paddle1_offset``  [0.45, 0.9] m: paddle 1's x less paddle 0's (fixed at x = 0.25), along the ball's way
    ``paddle2_offset``  [0.45, 0.9] m: paddle 2's x less paddle 1's, along the ball's way

    Hidden parameter (:mod:`phyplan_envs.hidden_physics`): ``paddle_restitution`` nominal 0.1, train [0.05, 0.25],
    test [0.02, 0.05) U (0.25, 0.4], one value for every paddle. A ball arriving at a paddle's face rebounds by
    Newton's law, ``v - (1 + e) (v . n) n`` (frictionless), resolved exactly inside the timestep
    (:mod:`phyplan_envs.hidden_physics.impacts`); it hops down the face until a rebound would be slower than
    0.05 m/s, then glides on Paddles' own overdamped contact, which also takes every touch of a board's edges,
    corners and underside. Where the ball leaves a paddle, and whether it touches it again, depend on the
    restitution. Goal: x uniform in the band where chain actions land at the context's restitution (measured per N
    and restitution: :func:`phyplan_envs.hidden_physics.tasks.paddles_reach`), y = 0; a restitution under which
    no chain is common (above 0.3 at N = 3 and 4, above 0.25 from N = 5 on) is redrawn. State observation (float32, m)
    ``goal_x, goal_y, object_x, object_y, object_z, shelf_top, first_paddle_x``, end rule (with its episode cap
    growing with N beyond N = 6) and reward as Paddles-v2 (:class:`phyplan_envs.tasks.paddles.PaddlesEnv`).

    Converged in the timestep and not chaotic (``python -m benchmarks.design_checks.paddles --chaos 40 --per-context
    --depths 1 2 3 4 5 6 --physics-space train``; docs/depth.md, *Hidden physics*).

    Version History:
        v0: first version, on Paddles-v0 (kept registered and reproducible:
        :class:`phyplan_envs.tasks.varied_v0.PaddlesVariedEnvV0`).
        v1: on Paddles-v1 (each placed paddle's offset from the one above; v1's goal ranges; kept registered and
        reproducible: :class:`phyplan_envs.tasks.varied_v0.PaddlesVariedEnvV1`).
        v2: on Paddles-v2 (the episode cap grows with N beyond N = 6; v1's outcomes up to N = 6; kept registered
        and reproducible: :class:`phyplan_envs.tasks.varied_v0.PaddlesVariedEnvV2`).
        v3: the restitution as exact impacts on the boards' own contact, in place of v0-v2's soft impact pair,
        whose rebound depended on where in a timestep the ball arrived: v2's landings were neither converged in
        the timestep nor stable.
    """)
