"""LaunchBounce: a pendulum hits a ball off a pedestal onto a wedge the agent places; the ball bounces off it into
a goal box behind the pendulum."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import PhyPlanEnv
from ..contact import restitution_of_solref
from ..tools import PENDULUM_DIMS, Ball, GoalBox, Pedestal, PendulumRig, PlacedWedge, placed_wedge_dims
from ..tools.supports import polar_goal
from .launch import LaunchFacts

WEDGE_DISTANCE = (0.2, 1.0)          # m from the pedestal
WEDGE_ANGLE = (0.0, math.pi / 2)     # rad: the wedge's direction from the pedestal
GOAL_DISTANCE = (0.3, 0.6)           # m from the pedestal
GOAL_ANGLE = (math.pi, 2 * math.pi)  # rad: behind the pendulum's quadrant of hits
TIMESTEP = 0.00025                   # s (v0: 0.0005; docs/composition.md, *Certificates*)


@dataclass(frozen=True)
class LaunchBounceFacts(LaunchFacts):
    """LaunchBounce's physical facts (m, kg, rad): Launch's pendulum, pedestal and ball, and the wedge on the ground.

    Attributes:
        wedge_half: half edge of the wedge's square base; its ridge is ``2 * wedge_half * tan(wedge_angle)`` high.
        wedge_angle: the incline's angle.
        incline_solref, incline_restitution: the ball-wedge contact (frictionless, Bounce's) and its nominal
            restitution.
    """

    wedge_half: float = assets.WEDGE_HALF
    wedge_angle: float = assets.WEDGE_ANGLE
    incline_solref: str = assets.ELASTIC_SOLREF
    incline_restitution: float = restitution_of_solref(assets.ELASTIC_SOLREF)


FACTS = LaunchBounceFacts()
BALL_START = np.array(FACTS.ball_start)
WEDGE_REST = (-0.6, 0.6, 0.0)        # the wedge's pose between attempts: out of the way, seen by the obs camera
WEDGE_DIMS = placed_wedge_dims(WEDGE_DISTANCE, WEDGE_ANGLE)
# The Panda stands beside the pedestal, outside the half plane of the goals (y < 0) and the quadrant of the wedges
# (x, y > 0): from there its hand reaches the bob at every release angle in every swing plane (a 5 x 3 grid of
# phi and theta), where from (-0.35, 0.35) it missed phi >= 1.2 rad.
PANDA_BASE = (-0.45, 0.1, 0.0)
PANDA_YAW = -0.2


class LaunchBounceEnv(PhyPlanEnv):
    """``PhyPlan/LaunchBounce-v1``: hit a ball off a pedestal with the pendulum onto a wedge you place, so that it
    bounces off the wedge into a goal box behind the pendulum (out of the pendulum's reach on its own).

    ==================  =====================  ====  ===========================================================
    action              bounds                 unit  meaning
    ==================  =====================  ====  ===========================================================
    ``phi``             [0, pi/2]              rad   plane of the pendulum's swing (direction the ball is hit)
    ``theta``           [pi/4, pi/2]           rad   release angle of the pendulum from vertical
    ``wedge_distance``  [0.2, 1.0]             m     distance of the wedge's axis from the pedestal
    ``wedge_angle``     [0, pi/2]              rad   direction of the wedge's axis from the pedestal (from +x)
    ``wedge_yaw``       [-pi, pi]              rad   yaw of the wedge: its incline falls towards ``wedge_yaw``
    ==================  =====================  ====  ===========================================================

    Scene: Launch's pedestal, ball and pendulum (:class:`~phyplan_envs.tasks.launch.LaunchEnv`), and Bounce's 45
    degree wedge (base 0.3 x 0.3 m, ridge 0.3 m high, frictionless elastic incline ``solref="-200000 -15"``) standing
    on the ground, without its stand: the ball, leaving the pedestal top 0.33 m up, meets the incline's lower part.
    An attempt places the wedge's axis ``wedge_distance`` from the pedestal along ``wedge_angle``, yawed to
    ``wedge_yaw`` (its incline falls towards that direction); between attempts it rests at (-0.6, 0.6).
    A ball flying along ``phi`` bounces back over the pedestal when the incline rises away from it (``wedge_yaw``
    near ``phi + pi``) and to the side as the yaw turns; the ball meets the wedge only where its flight passes over
    the wedge's footprint before it lands (the wedge within ~0.15 m of the direction ``phi`` and at most ~0.8 m out).

    State observation (float32, m): ``goal_x, goal_y, object_x, object_y, object_z, pivot_height`` (as Launch).
    Context: goal at distance U(0.3, 0.6) m from the ball, direction U(pi, 2 pi) (the half plane y < 0, behind the
    pendulum's quadrant of hits: no flight reaches it without the wedge).
    Episode end: the ball's centre falls below ``BALL_RADIUS + 0.01`` m (it lands; xy interpolated at the crossing),
    the ball rests, or 4 s pass.
    Reward: ``1 - d/d0`` with d the xy distance of the landing point from the goal centre, d0 the ball's at reset.
    Timestep 0.25 ms (the end rule every 5 ms): at v0's 0.5 ms the landings of bouncing actions had not converged in
    the timestep (docs/composition.md, *Certificates*).
    Physical facts: :attr:`facts`, a :class:`LaunchBounceFacts`.
    Certificates (figures: docs/composition.md, *Certificates*): ``python -m benchmarks.solvability --tasks
    launch-bounce --contexts 50 --first-seed 200000 --budget 1500`` (every context solvable), ``python -m
    benchmarks.design_checks.launch_bounce --chaos --wedge-needed 50 --seed 7310000 --seed-step 7919`` (converged,
    not chaotic; the wedge needed).

    The Panda stands at (-0.45, 0.1), beside the pedestal and outside the goals' half plane and the wedges'
    quadrant; in robot mode it swings the pendulum as in Launch and the scene places the wedge, as in Bounce.

    Version History:

    * v0: first release: the pendulum, the ball on its pedestal and a wedge placed on the ground (the original
      code's ``pendulum_wedge``, with the wedge's direction in the pendulum's quadrant of hits); timestep 0.5 ms
      (kept registered and reproducible: :class:`phyplan_envs.tasks.launch_bounce_v0.LaunchBounceEnvV0`).
    * v1: timestep 0.25 ms, so that the landing converges in the timestep (the scene, actions, context and reward
      are v0's).
    """

    task_name = "launch-bounce"
    object_name = "ball"
    action_dims = PENDULUM_DIMS + WEDGE_DIMS
    facts = FACTS
    end_rule = "landed"
    landing_height = FACTS.landing_height
    state_extra = ("pivot_height",)
    object_start = BALL_START
    cameras = (("obs", (0.15, -1.9, 2.5), (0.15, 0.1, 0.1), 50), ("view", (1.6, -1.9, 1.5), (0.1, 0.05, 0.2), 50))
    panda_base = (PANDA_BASE, PANDA_YAW)
    timestep = TIMESTEP
    chunk = 20                           # the end rule checked every 5 ms, as the other tasks

    def assemble(self):
        f = self.facts
        ball = Ball(self.object_start, mass=f.ball_mass)
        self.pendulum = self.hand_tool = PendulumRig(ball, bob_dz=f.bob_dz, bob_mass=f.bob_mass)
        self.wedge = PlacedWedge(BALL_START, WEDGE_DIMS, WEDGE_REST)
        return [Pedestal(BALL_START[:2]), self.pendulum, ball, self.wedge, GoalBox()]

    def sample_goal(self, rng):
        return polar_goal(rng, BALL_START, GOAL_DISTANCE, GOAL_ANGLE)

    def task_state(self):
        return [BALL_START[2] + self.facts.pendulum_length]
