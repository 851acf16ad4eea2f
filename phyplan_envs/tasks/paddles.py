"""Paddles-N: the pendulum pushes a ball off a high shelf; it falls through N tilted paddles the agent places and
lands in a goal on the floor."""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..base import PhyPlanEnv
from ..tools import Ball, GoalBox, PandaStand, PendulumFacts, PendulumRig
from ..tools.paddles import Paddle, PaddleChain, Shelf, chained_x

THETA = (0.2, 0.5)            # rad: the release angles (the original code's): a gentle push off the shelf
OFFSET_SPAN = (0.45, 0.9)     # m: each placed paddle's x less the x of the paddle above, along the ball's way
FIRST_PADDLE_X = 0.25         # m: the fixed first paddle's centre: every release angle's ball meets its face
MAX_PADDLES = 12              # the largest N the env builds (the benchmark covers 1-6)
# The episode cap. LANDS_IN_TIME: the largest N whose balls landed within v1's 4 s (assets.MAX_SIM_TIME) on every
# action measured (python -m benchmarks.design_checks.paddles --episode-end 200 --depths 6 7 8 9 10 11 12 --version
# 1). v2's cap: 4 s up to N = CAP_GROWS_AFTER, CAP_PER_PADDLE more per paddle beyond (the falls take up to 5.71 s
# at N = 12, the same command with --version 2; PaddlesVaried's hops take up to 3.75 s at N = 7, the same command
# with --physics-space test, so the growth starts one paddle early).
LANDS_IN_TIME = 7
CAP_GROWS_AFTER = 6
CAP_PER_PADDLE = 0.75         # s
TIMESTEP = 0.0005             # s
# Goals: on the line y = 0 ahead of the shelf (the last paddle throws towards +x), x in U(GOAL_RANGE[N]) (m): the
# p5-p95 of the landings of chain actions (actions whose ball meets every paddle), measured per N by
# python -m benchmarks.design_checks.paddles --reach 100 --depths 2 3 4 5 6, and at least GOAL_NEAREST from the
# ball's start (the reward divides by that distance); N = 1 (no placed paddle: v0's scene) keeps v0's range; N > 6
# takes the band of 5 or 6 of the same parity.
GOAL_NEAREST = 0.3
GOAL_RANGE = {1: (1.406, 1.414), 2: (0.355, 0.903), 3: (0.900, 1.674), 4: (GOAL_NEAREST, 1.039),
              5: (0.746, 1.818), 6: (GOAL_NEAREST, 1.219)}
PANDA_OFFSET = (-0.45, 0.1)   # the Panda beside the shelf, as LaunchBounce's beside its pedestal
PANDA_YAW = -0.2
PANDA_STAND_HALF = 0.09


@dataclass(frozen=True)
class PaddlesFacts(PendulumFacts):
    """Paddles-N's physical facts (m, kg, rad) for ``paddles`` paddles.

    Attributes:
        paddles: N, the number of paddles.
        shelf_top: height of the shelf's top, ``N + 1.5`` (the original code's).
        ball_radius, ball_mass: Launch's ball; it rests on the shelf's front edge at x = 0.
        paddle_z: the paddles' face-centre heights, the i-th (from 0) at ``shelf_top - 0.5 - i``.
        paddle_falls: +1 where the i-th paddle's face falls towards +x, -1 towards -x: alternately, the last one
            towards +x (so that every N throws the ball ahead of the shelf at the end).
        first_paddle_x: the fixed first paddle's x.
        paddle_half, paddle_tilt: half edge of the square paddles and their tilt from horizontal.
        paddle_restitution: the ball-paddle contact's nominal restitution (frictionless).
        landing_height: the episode ends when the ball's centre falls through this height.
    """

    paddles: int = 3
    ball_radius: float = assets.BALL_RADIUS
    ball_mass: float = assets.BALL_MASS
    first_paddle_x: float = FIRST_PADDLE_X
    paddle_half: float = assets.PADDLE_HALF
    paddle_tilt: float = assets.PADDLE_TILT
    paddle_restitution: float = assets.PADDLE_RESTITUTION
    landing_height: float = assets.BALL_RADIUS + 0.01

    @property
    def shelf_top(self) -> float:
        return self.paddles + 1.5

    @property
    def paddle_z(self) -> tuple[float, ...]:
        return tuple(self.shelf_top - 0.5 - i for i in range(self.paddles))

    @property
    def paddle_falls(self) -> tuple[int, ...]:
        return tuple(1 if (self.paddles - 1 - i) % 2 == 0 else -1 for i in range(self.paddles))

    @property
    def ball_start(self) -> tuple[float, float, float]:
        return (0.0, 0.0, self.shelf_top + self.ball_radius)


def goal_range(paddles: int, ranges: dict[int, tuple[float, float]] | None = None) -> tuple[float, float]:
    """The goals' x range (m) for N = ``paddles`` in ``ranges`` (default :data:`GOAL_RANGE`; N > 6: N = 5's or 6's,
    of the same parity)."""
    ranges = GOAL_RANGE if ranges is None else ranges
    return ranges[paddles] if paddles in ranges else ranges[6 if paddles % 2 == 0 else 5]


def check_paddles(paddles) -> int:
    """``paddles`` as an int in [1, MAX_PADDLES]; ``TypeError``/``ValueError`` naming it otherwise."""
    if isinstance(paddles, bool) or not isinstance(paddles, (int, np.integer)):
        raise TypeError(f"paddles must be an int, got {type(paddles).__name__}")
    if not 1 <= int(paddles) <= MAX_PADDLES:
        raise ValueError(f"paddles must be in [1, {MAX_PADDLES}], got {paddles}")
    return int(paddles)


class PaddlesEnv(PhyPlanEnv):
    """``PhyPlan/Paddles-v2`` (``gym.make("PhyPlan/Paddles-v2", paddles=N)``, N >= 1, default 3): push a ball off a
    high shelf with the pendulum so that it falls through N tilted paddles, each placed relative to the one above,
    into a goal on the floor.

    ==================  ===========  ====  =====================================================================
    action              bounds       unit  meaning
    ==================  ===========  ====  =====================================================================
    ``theta``           [0.2, 0.5]   rad   release angle of the pendulum from vertical (it swings along +x)
    ``paddle1_offset``  [0.45, 0.9]  m     paddle 1's x less paddle 0's (fixed at x = 0.25), along the way the
                                           ball leaves paddle 0
    ``paddle2_offset``  [0.45, 0.9]  m     paddle 2's x less paddle 1's, along the way the ball leaves paddle 1
    ==================  ===========  ====  =====================================================================

    The table is N = 3's; with N paddles the actions are ``theta`` and ``paddle1_offset`` .. ``paddle<N-1>_offset``,
    each in [0.45, 0.9] m (N = 1: ``theta`` alone). Paddle i's x is paddle i-1's plus its offset times the direction
    paddle i-1's face falls towards (+1 or -1): moving one offset moves that paddle and every paddle below it.

    Scene (the original code's ``paddles``): a frictionless floating shelf with its top at ``N + 1.5`` m and its
    front edge at x = 0, where Launch's ball rests; Launch's pendulum behind it, swinging in the xz plane. N paddles,
    0.5 m square boards (0.02 m thick) tilted 45 degrees alternately, the last one's face falling towards +x,
    frictionless and overdamped (they keep none of the ball's normal speed), the i-th (from 0) with its face centre
    at ``N + 1.0 - i`` m. Pushed off the shelf, the ball meets paddle 0, glides down it, leaves its lower edge,
    meets paddle 1 if it is placed under that flight, and so on; from the last paddle it falls to the floor. The
    chain: swing, hit, then (throw, bounce, glide) per paddle, then the last throw. Between attempts the placed
    paddles rest at the offsets' midpoint, 0.675 m.

    State observation (float32, m): ``goal_x, goal_y, object_x, object_y, object_z, shelf_top, first_paddle_x``.
    Context: the goal on the line y = 0 ahead of the shelf, x uniform in a per-N range (:data:`GOAL_RANGE`: where
    the chains that meet every paddle land, p5-p95, at least 0.3 m from the ball; docs/depth.md).
    Episode end: the ball's centre falls below ``BALL_RADIUS + 0.01`` m (it lands; xy interpolated at the
    crossing), the ball rests, or the episode cap passes: 4 s up to N = 6, 0.75 s more per paddle beyond
    (:attr:`max_sim_time`; every fall measured lands within it, docs/depth.md).
    Reward: ``1 - d/d0``, d the landing point's xy distance from the goal centre, d0 the ball's at reset.
    Timestep 0.5 ms (the end rule every 5 ms). Physical facts: :attr:`facts`, a :class:`PaddlesFacts`.
    Certificates (docs/depth.md): ``python -m benchmarks.design_checks.paddles`` (solvable, every
    paddle matters, converged, not chaotic, per N).

    The Panda stands on a stand beside the shelf (its base 0.45 m behind the ball and 0.33 m below it, as in
    LaunchBounce); in robot mode it swings the pendulum and the scene places the paddles.

    Version History:

    * v0: first release (the original code's unfinished ``paddles``, with a bounce model and any N): the placed
      paddles' absolute x in [-1, 1] m (:class:`phyplan_envs.tasks.paddles_v0.PaddlesEnvV0`, kept registered).
    * v1: each placed paddle's offset from the one above, so that balls skip no paddle and every paddle's place
      carries to the landing; goal ranges from v1's chains (:class:`phyplan_envs.tasks.paddles_v1.PaddlesEnvV1`,
      kept registered).
    * v2: the episode cap grows with N beyond N = 6, where v1's 4 s ended most falls in the air from N = 9 on; the
      same outcomes as v1 up to N = 6 (and beyond, where v1's ball landed within 4 s).
    """

    task_name = "paddles"
    object_name = "ball"
    end_rule = "landed"
    landing_height = assets.BALL_RADIUS + 0.01
    state_extra = ("shelf_top", "first_paddle_x")
    timestep = TIMESTEP
    chunk = 10
    scene_args = ("paddles",)          # the constructor arguments that change the scene (for planners' copies)
    paddle_half = assets.PADDLE_HALF   # the paddles' half edge, tilt and restitution, and the offsets' bounds (a
    paddle_tilt = assets.PADDLE_TILT   # design study's subclass may set others)
    paddle_restitution = assets.PADDLE_RESTITUTION
    offset_span = OFFSET_SPAN
    goal_ranges = GOAL_RANGE
    cap_per_paddle = CAP_PER_PADDLE    # s: the episode cap's growth per paddle beyond N = 6 (v0 and v1: none)

    def __init__(self, paddles: int = 3, **kwargs):
        n = check_paddles(paddles)
        if not self.cap_per_paddle and n > LANDS_IN_TIME:
            warnings.warn(f"Paddles v0/v1 with paddles={n}: the ball falls for longer than their 4 s episode cap on "
                          "some actions (most from N = 9 on); those episodes end with it in the air "
                          "(info['end_reason'] == 'timeout'), rewarded where it is then; Paddles-v2's cap grows with "
                          "N (docs/depth.md)", stacklevel=2)
        self.paddles = n
        self.facts = PaddlesFacts(paddles=n, paddle_half=self.paddle_half, paddle_tilt=self.paddle_tilt,
                                  paddle_restitution=self.paddle_restitution)
        self.object_start = np.array(self.facts.ball_start)
        top = self.facts.shelf_top
        base = (PANDA_OFFSET[0], PANDA_OFFSET[1], top + assets.BALL_RADIUS - 0.333)
        self.panda_base = (base, PANDA_YAW)
        mid = top / 2
        # obs: the floor where the goals lie and the lowest paddles, from above and in front (as LaunchBounce's);
        # view (render): the whole tower
        self.cameras = (("obs", (0.7, -2.1, 2.6), (0.7, 0.1, 0.3), 50),
                        ("view", (2.5, -(top + 2.5), mid + 0.5), (0.0, 0.0, mid), 50))
        self.action_dims = self._make_tools()
        super().__init__(**kwargs)

    @property
    def max_sim_time(self) -> float:
        """The episode cap (s): 4 s up to N = :data:`CAP_GROWS_AFTER`, :attr:`cap_per_paddle` more per paddle
        beyond."""
        return assets.MAX_SIM_TIME + self.cap_per_paddle * max(0, self.paddles - CAP_GROWS_AFTER)

    def _make_tools(self):
        f = self.facts
        ball = Ball(self.object_start, mass=f.ball_mass)
        self.pendulum = self.hand_tool = PendulumRig(ball, bob_dz=f.bob_dz, bob_mass=f.bob_mass, plane=0.0,
                                                     theta_range=THETA)
        placing = self._placing_tools()
        self._tools = [Shelf(f.shelf_top, 0.0 + assets.BALL_RADIUS), self.pendulum, ball, *placing, GoalBox()]
        if self.with_panda_requested:
            self._tools.append(PandaStand(self.panda_base[0], PANDA_STAND_HALF))
        return self.pendulum.dims + tuple(d for t in placing for d in t.dims)

    def _paddle(self, i: int, **place) -> Paddle:
        """Paddle ``i`` with the task's facts, placed by ``place`` (``x=`` or ``span=`` and ``rest_x=``)."""
        f = self.facts
        return Paddle(i, f.paddle_z[i], f.paddle_falls[i], restitution=f.paddle_restitution, half=f.paddle_half,
                      tilt=f.paddle_tilt, **place)

    def _placing_tools(self) -> list:
        """The tools that hold and place the paddles: one :class:`PaddleChain`, the placed paddles resting at the
        offsets' midpoint."""
        f = self.facts
        xs = chained_x(f.first_paddle_x, f.paddle_falls, np.full((1, f.paddles - 1), np.mean(self.offset_span)))[0]
        self.paddle_chain = PaddleChain([self._paddle(i, x=float(x)) for i, x in enumerate(xs)], self.offset_span)
        return [self.paddle_chain]

    def paddle_x(self, actions) -> np.ndarray:
        """The paddles' x (K, N) for the actions ``actions`` (K, action_dim, or one action)."""
        a = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        return self.paddle_chain.x(a[:, 1:])

    @property
    def with_panda_requested(self) -> bool:
        return bool(self._init_args[1].get("with_panda", True))

    def assemble(self):
        return self._tools

    def sample_goal(self, rng):
        lo, hi = goal_range(self.paddles, self.goal_ranges)
        return np.array([rng.uniform(lo, hi), 0.0])

    def task_state(self):
        return [self.facts.shelf_top, self.facts.first_paddle_x]
