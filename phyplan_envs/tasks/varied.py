"""The varied tasks: each context also draws hidden physics (see :mod:`phyplan_envs.hidden_physics`).

``PhyPlan/LaunchVaried-v0``, ``SlideVaried-v0``, ``BounceVaried-v0`` and ``BridgeVaried-v0`` keep the action space,
observation, end rule and reward of their nominal task. What differs (all documented per class):

* hidden parameters drawn per context from the train or test space (:data:`phyplan_envs.hidden_physics.PARAMETERS`);
  they are in neither the observation, ``info`` nor the context (which holds a ``physics_token``, the context's
  physics sealed under a secret of the process: :class:`VariedPhysicsMixin`); the privileged
  :attr:`VariedPhysicsMixin.hidden_physics` returns them;
* the goal is drawn after the physics and redrawn until it is reachable under it (a closed-form reach band of the
  task, :meth:`reach_band`, shrunk by ``REACH_MARGIN``); if the band misses the goal region the physics is redrawn.
  The goal therefore carries some information about the physics (a far goal means a "fast" context);
* timestep 0.5 ms, and the attempt starts at the first touch: the ball's free fall onto the incline (Bounce) and the
  pendulum's frictionless swing (the others) are integrated in closed form and the simulation starts with the
  bodies exactly touching at the energy-conserving speed, so the contact's start does not depend on where it falls
  between two time steps (the nominal tasks' sawtooth); ``info["sim_time"]`` counts the simulated part only;
* the bob collides through a sphere (its own body, mass per context); the puck starts on a 0.5 mm frictionless pad.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import assets
from ..block import BLOCK_HALF, add_square_top, make_block
from .. import hidden_physics as hp
from ..base import polar
from ..varied_physics import (SETTLE_TIME, TIMESTEP, TOUCH_OVERLAP, PendulumVariedMixin, PuckVariedMixin,
                              VariedPhysicsMixin)
from .bounce import DROP_XY, BounceEnv
from .bridge import PUCK_START as BRIDGE_PUCK_START
from .bridge import BridgeEnvV0
from .launch import BALL_START, LaunchEnv
from .slide import PUCK_START as SLIDE_PUCK_START
from .slide import SlideEnv

__all__ = ["BounceVariedEnv", "BridgeVariedEnv", "BridgeVariedEnvV0", "LaunchVariedEnv", "SETTLE_TIME",
           "SlideVariedEnv", "SlideVariedEnvV0", "TIMESTEP", "TOUCH_OVERLAP", "VariedPhysicsMixin"]


class LaunchVariedEnv(PendulumVariedMixin, LaunchEnv):
    """``PhyPlan/LaunchVaried-v0``: Launch with a hidden bob mass and bob-ball restitution.

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.05, 0.3) U (1.0, 3.0] (log-uniform); ``restitution`` (bob-ball) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]. The test split draws from the test space, train and dev from the train space.
    Only their combination k ~ (1 + e) m/(m + m_ball) (the launch speed over the bob speed) shows in a landing.
    Goal: distance U(0.3, 1.0) m from the ball, direction U(0, pi/2), redrawn until reachable under the context's
    physics (see :mod:`phyplan_envs.tasks.varied`). Same actions, observation, end rule and reward as Launch-v0.

    Version History:
        v0: first version.
    """

    task_name = "launch-varied"
    base_task = "launch"
    object_geom = "ball_geom"
    goal_distance_range = (0.3, 1.0)
    reach_origin = BALL_START[:2]

    def sample_goal(self, rng):
        return BALL_START[:2] + polar(rng.uniform(*self.goal_distance_range), rng.uniform(0.0, math.pi / 2))

    def reach_band(self, values):
        fall = math.sqrt(2 * (BALL_START[2] - self.landing_height) / assets.GRAVITY)
        lo, hi = (self.action_dims[1].low, self.action_dims[1].high)
        return self.launch_speed(values, lo) * fall, self.launch_speed(values, hi) * fall


class SlideVariedEnvV0(PuckVariedMixin, SlideEnv):
    """``PhyPlan/SlideVaried-v0``: Slide with a hidden bob mass, bob-puck restitution and table friction.

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.1, 0.3) U (1.0, 6.0] (log-uniform); ``restitution`` (bob-puck) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]; ``friction`` (puck-table) nominal 0.35, train [0.25, 0.45], test
    [0.15, 0.25) U (0.45, 0.6]. The test split draws from the test space, train and dev from the train space.
    The stopping distance depends on them through k^2 / mu (k: launch speed over bob speed) only.
    The puck starts on a 9 cm frictionless pad 0.5 mm above the table (the push happens on it).
    Goal: distance U(0.35, 1.65) m from the puck, direction U(0, pi/2), redrawn until reachable under the context's
    physics. Same actions, observation, end rule and reward as Slide-v0.

    Version History:
        v0: first version (kept registered and reproducible; superseded by v1, :class:`SlideVariedEnv`).
        v1: the puck is a square block turned to the swing plane, on a square pad; slow friction reference.
    """

    task_name = "slide-varied"
    base_task = "slide"
    facts = dataclasses.replace(SlideEnv.facts, bob_dz=0.0, table_friction=hp.FRICTION.nominal)
    object_start = SLIDE_PUCK_START + np.array([0.0, 0.0, hp.PAD_RISE])
    reach_origin = SLIDE_PUCK_START[:2]
    goal_distance_range = (0.35, 1.65)

    def reach_band(self, values):
        return (self.stop_distance(values, self.action_dims[1].low),
                self.stop_distance(values, self.action_dims[1].high))


class BridgeVariedEnvV0(PuckVariedMixin, BridgeEnvV0):
    """``PhyPlan/BridgeVaried-v0``: Bridge with a hidden bob mass, bob-puck restitution and table/plank friction.

    Hidden parameters (:mod:`phyplan_envs.hidden_physics`): ``bob_mass`` nominal 0.5 kg, train [0.3, 1.0], test
    [0.1, 0.3) U (1.0, 6.0] (log-uniform); ``restitution`` (bob-puck) nominal 0.5, train [0.35, 0.65], test
    [0.05, 0.35) U (0.65, 0.95]; ``friction`` (puck on the table top and on the plank, one value) nominal 0.35,
    train [0.25, 0.45], test [0.15, 0.25) U (0.45, 0.6]. The test split draws from the test space, train and dev
    from the train space. The puck starts on a 9 cm frictionless pad 0.5 mm above the table.
    Goal: distance U(0.9, 1.4) m from the table centre, direction U(0, pi/2), redrawn until reachable under the
    context's physics (high friction with a slow puck leaves only the nearer goals). Same actions, observation,
    end rule and reward as Bridge-v0.

    Version History:
        v0: first version (kept registered and reproducible; superseded by v1, :class:`BridgeVariedEnv`).
        v1: the puck is a square block turned to the swing plane, on a square pad; the round table top collides as
        a square turned with it; slow friction reference.
    """

    task_name = "bridge-varied"
    base_task = "bridge"
    facts = dataclasses.replace(BridgeEnvV0.facts, bob_dz=0.0, table_friction=hp.FRICTION.nominal)
    object_start = BRIDGE_PUCK_START + np.array([0.0, 0.0, hp.PAD_RISE])
    reach_origin = BRIDGE_PUCK_START[:2]
    goal_distance_range = (0.9, 1.4)
    friction_geoms = (("table_top", "object_table"), ("bridge_plank", "object_plank"))

    def end_distance(self, values, theta: float) -> float:
        """Closed form: where the puck stops on the table or plank, or lands beyond the plank's end."""
        edge = assets.BRIDGE_TABLE_RADIUS + assets.BRIDGE_LENGTH
        stop = self.stop_distance(values, theta)
        if stop <= edge:
            return stop
        v = self.launch_speed(values, theta)
        v_end = math.sqrt(v * v - 2 * values["friction"] * assets.GRAVITY * (edge - hp.PAD_RADIUS))
        drop = assets.TABLE_HEIGHT - assets.BRIDGE_DROP + assets.PUCK_HALF_HEIGHT - self.landing_height
        return edge + v_end * math.sqrt(2 * drop / assets.GRAVITY)

    def reach_band(self, values):
        return (self.end_distance(values, self.action_dims[1].low),
                self.end_distance(values, self.action_dims[1].high))


_BLOCK_DOC = """
    v1 changes only the puck's contacts, so that the outcome converges in the timestep (v0 and v1 measured by
    ``python -m benchmarks.design_checks.hidden_physics --only convergence [--version 0]``; figures in
    docs/hidden-physics.md):

    * the puck is a square block of the disc's footprint area (half edge 17.7 mm, same mass and thickness,
      :func:`phyplan_envs.make_block`), on a square frictionless pad of half edge 4.5 cm; before each
      attempt both are turned to the swing plane ``phi`` (the bob hits the middle of a face; the block leaves the pad
      4.5 cm along its path, as v0's disc left its round pad). In robot mode the scene turns them, not the arm;
    * the friction pairs have a slow friction reference (``solreffriction`` (0.05, 1)): the sliding block's hops
      are sub-millimetre instead of millimetres;
"""


class SlideVariedEnv(SlideVariedEnvV0):
    __doc__ = """``PhyPlan/SlideVaried-v1``: SlideVaried-v0 (below) with the puck as a block facing the swing plane.
    """ + _BLOCK_DOC + """
    everything else (hidden parameters, spaces, goals, end rule, reward) is v0's.

    Version History:
        v0: first version (:class:`SlideVariedEnvV0`).
        v1: the block (above).
    """

    block = True
    object_half = BLOCK_HALF


class BridgeVariedEnv(BridgeVariedEnvV0):
    __doc__ = """``PhyPlan/BridgeVaried-v1``: BridgeVaried-v0 (below) with the puck as a block facing the swing plane.
    """ + _BLOCK_DOC + """    * the round table top collides as a square of half edge 0.25 m turned with the block (MuJoCo collides a box
      with a cylinder through the convex collider too): along the block's path from the table centre its rim is
      the disc's rim, 0.25 m out; the table is drawn round;
    * goals at distance U(0.6, 1.4) m from the table centre (v0: U(0.9, 1.4)), still redrawn until reachable: the
      goals short of the plank's end (1.0 m) are stops on the plank (their marker lies on the floor below it), as
      friction-sensitive as Slide's. With v0's goals a planner that ignores the hidden physics (the oracle's
      search on the nominal simulator) kept a regret below the 0.10 that makes the track test adaptation; with
      these it does not (``python -m benchmarks.design_checks.hidden_physics --only nominal --tasks bridge
      [--version 0]``; figures in docs/hidden-physics.md);

    everything else (hidden parameters, spaces, plank, end rule, reward) is v0's.

    Version History:
        v0: first version (:class:`BridgeVariedEnvV0`).
        v1: the block, the square table-top collider and the wider goal range (above).
    """

    block = True
    object_half = BLOCK_HALF
    turned_bodies = (hp.PAD_BODY, "table")
    goal_distance_range = (0.6, 1.4)

    def add_hidden_contacts(self, root) -> None:
        add_square_top(root, "table_top", assets.BRIDGE_TABLE_RADIUS, **assets.WORLD)
        super().add_hidden_contacts(root)


class BounceVariedEnv(VariedPhysicsMixin, BounceEnv):
    """``PhyPlan/BounceVaried-v0``: Bounce with a hidden ball-incline restitution.

    Hidden parameter (:mod:`phyplan_envs.hidden_physics`): ``restitution`` (ball-incline) nominal 0.8, train
    [0.7, 0.9], test [0.4, 0.7) U (0.9, 0.99]. The test split draws from the test space, train and dev from the
    train space. A lower restitution sends the ball off slower and downwards: at e = 0.5 the landing range is
    0.36-0.59 m, at 0.8 0.39-0.87 m, at 0.98 0.44-1.1 m (drop heights 0.5-1.5 m).
    The wedge's round stand has radius 0.15 m (Bounce-v0: 0.22 m), so that a slow, low ball clears it.
    Goal: the Bounce-v0 sampler, redrawn until its distance from the wedge axis is reachable under the context's
    restitution. Same actions, observation, end rule and reward as Bounce-v0.

    Version History:
        v0: first version.
    """

    task_name = "bounce-varied"
    base_task = "bounce"
    reach_origin = DROP_XY
    stand_radius = 0.15

    def add_hidden_contacts(self, root) -> None:
        stand = root.find("geom", "wedge_stand")
        stand.size = (self.stand_radius, stand.size[1])
        hp.add_impact_pair(root, "ball_geom", "wedge_incline", "ball_incline", hp.INCLINE_RESTITUTION.nominal,
                           hp.INCLINE_STIFFNESS)

    def set_hidden(self, values) -> None:
        hp.set_restitution(self.model, "ball_incline", values["restitution"], hp.INCLINE_STIFFNESS)

    def sample_goal(self, rng):
        return BounceEnv.sample_context(self, rng)["goal"]

    def landing_range(self, restitution: float, height: float) -> float:
        """Closed form: a mirror bounce off the frictionless 45 degree incline, then a projectile to the ground."""
        z = assets.WEDGE_IMPACT_Z
        v = math.sqrt(2 * assets.GRAVITY * (height - z))
        vx, vz = v * (1 + restitution) / 2, -v * (1 - restitution) / 2
        t = (vz + math.sqrt(vz * vz + 2 * assets.GRAVITY * (z - self.landing_height))) / assets.GRAVITY
        return vx * t

    def reach_band(self, values):
        return (self.landing_range(values["restitution"], self.action_dims[1].low),
                self.landing_range(values["restitution"], self.action_dims[1].high))

    def apply_action(self, action) -> None:
        super().apply_action(action)
        z = assets.WEDGE_IMPACT_Z - TOUCH_OVERLAP * math.sqrt(2)
        v = math.sqrt(2 * assets.GRAVITY * (float(action[1]) - z))
        self.set_object_pose((DROP_XY[0], DROP_XY[1], z), vel=(0.0, 0.0, -v))

    def _execute(self, action) -> None:
        super()._execute(action)
        if self._robot is not None and self._robot_report.ok:
            # robot mode: the arm has let the ball go; its free fall to the incline is in closed form from the
            # state the arm left it in, as in the kinematic mode (the release's xy offset and speed are kept)
            import mujoco

            q, dq = self._obj_qpos, self._obj_qvel
            pos, vel = self.data.qpos[q:q + 3].copy(), self.data.qvel[dq:dq + 3].copy()
            # the height at which the ball, at its released xy, exactly touches the incline as the arm turned it
            # (a gap or overlap of a micrometre would start the contact between two steps: the sawtooth that the
            # first-touch start removes)
            wedge = self.body_id("wedge")
            qw = self.data.xquat[wedge]
            yaw = 2 * math.atan2(qw[3], qw[0])
            axis = self.data.xpos[wedge]
            z = (assets.WEDGE_IMPACT_Z - TOUCH_OVERLAP * math.sqrt(2)
                 - math.cos(yaw) * (pos[0] - axis[0]) - math.sin(yaw) * (pos[1] - axis[1]))
            vz = -math.sqrt(vel[2] * vel[2] + 2 * assets.GRAVITY * max(0.0, pos[2] - z))
            self.set_object_pose((pos[0], pos[1], z), vel=(vel[0], vel[1], vz))
            mujoco.mj_forward(self.model, self.data)


def _append_nominal_doc(cls: type, nominal: type) -> None:
    """The varied task's docstring continues with its nominal task's (actions, observation, end rule, reward), a v1
    with its v0's."""
    what = "The previous version" if issubclass(nominal, VariedPhysicsMixin) else "The nominal task"
    cls.__doc__ = (cls.__doc__ or "") + f"\n    {what}, {nominal.__name__}:\n" + (nominal.__doc__ or "")


for _cls, _nominal in ((LaunchVariedEnv, LaunchEnv), (SlideVariedEnvV0, SlideEnv), (BounceVariedEnv, BounceEnv),
                       (BridgeVariedEnvV0, BridgeEnvV0), (SlideVariedEnv, SlideVariedEnvV0),
                       (BridgeVariedEnv, BridgeVariedEnvV0)):
    _append_nominal_doc(_cls, _nominal)
