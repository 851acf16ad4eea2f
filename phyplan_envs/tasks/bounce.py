"""Bounce: a ball dropped onto a yawed 45 degree wedge bounces off the incline and flies into a goal box."""
from __future__ import annotations

import math

import numpy as np

from .. import assets
from ..base import ActionDim, PhyPlanEnv

DROP_XY = np.array([0.0, 0.0])                 # the wedge's yaw axis: the ball is always released above it
WEDGE_POS = (DROP_XY[0], DROP_XY[1], 0.0)
WEDGE_NEUTRAL_YAW = 0.0                         # tool pose at reset, before any attempt (the obs camera sees its profile)
SIDE_TABLE_HALF = 0.1                           # reference side table: 0.2 x 0.2 x 1.0 m
SIDE_TABLE_HEIGHT = 1.0
SIDE_TABLE_XY = np.array([0.0, 0.45])           # behind the wedge, away from the goal area (goals have y < -0.3)
BALL_START = np.array([SIDE_TABLE_XY[0], SIDE_TABLE_XY[1], SIDE_TABLE_HEIGHT + assets.BALL_RADIUS])
# Goal sampling of the reference: x ~ U(-0.75, 0.75), y ~ U(-0.75, 0), redrawn until |x| > 0.3 and |y| > 0.3.
# With the wedge on its stand the landing ring (0.44-1.07 m from the wedge) covers all of it: see the docstring.
GOAL_X = (-0.75, 0.75)
GOAL_Y = (-0.75, 0.0)
GOAL_MIN_ABS = 0.3
# The Panda stands on a 0.5 m stand beside the wedge: from the ground its hand could not reach the 1.5 m drop height
# (measured with phyplan_envs.panda's IK: the grasp point is within 0.1 mm of every drop point 0.5-1.5 m and of the
# ball on the side table with the horizontal grasp of ``hand_axes``).
PANDA_BASE = (-0.5, 0.3, 0.5)
PANDA_YAW = -0.5
PANDA_STAND_HALF = 0.09


class BounceEnv(PhyPlanEnv):
    """``PhyPlan/Bounce-v0``: drop a ball onto a yawed 45 degree wedge so that it bounces into the goal box.

    ==============  =====================  ==========  =============================================================
    action          bounds                 unit        meaning
    ==============  =====================  ==========  =============================================================
    ``wedge_yaw``   [-pi, pi]              rad         yaw of the wedge about its vertical axis through the origin;
                                                       the ball flies off along direction ``wedge_yaw`` (from +x)
    ``drop_height`` [0.5, 1.5]             m           height of the ball's centre above the ground at release;
                                                       a higher drop lands farther
    ==============  =====================  ==========  =============================================================

    Scene: at reset the ball rests on a 0.2 x 0.2 x 1.0 m side table at (0, 0.45); the wedge (base 0.3 x 0.3, 45
    degree incline, ridge 0.3 m above its base) stands on a round stand (radius 0.22 m, 0.15 m high) at the origin in
    a fixed neutral pose (yaw 0). An attempt yaws the wedge, places the ball at rest at ``(0, 0, drop_height)``
    (straight above the yaw axis, so the ball meets the incline at the same point for every yaw) and releases it.

    State observation (float32, metres): ``goal_x, goal_y, object_x, object_y, object_z`` (the ball on the side
    table after reset, its landing point after a step), then ``wedge_x, wedge_y`` (the wedge's yaw axis = the drop
    point, (0, 0)) and ``impact_z`` (height of the ball's centre when it meets the incline, 0.328 m).
    Context: goal x ~ U(-0.75, 0.75), y ~ U(-0.75, 0), redrawn until |x| > 0.3 and |y| > 0.3 (the reference sampler,
    unchanged): 0.42-1.06 m from the wedge.
    Episode end: the ball's centre falls below ``BALL_RADIUS + 0.01`` m (it lands; xy interpolated at the crossing),
    the ball rests, or 4 s pass.
    Reward: ``1 - d/d0`` with d the xy distance of the landing point from the goal centre and d0 that of the ball on
    the side table at reset (0.81-1.42 m).
    Skill chain: throw (free fall onto the incline) -> bounce -> throw (projectile to the ground).

    Physical parameters: ball radius 0.02 m, 0.1 kg; the incline contact is frictionless (``condim=1``) with
    ``solref="-200000 -15"`` (``assets.ELASTIC_SOLREF``), only on the ball-incline pair (``priority=1``).
    Measured (``python -m phyplan_envs.tasks.bounce --measure``): normal restitution 0.94-0.95, outgoing speed
    0.98-1.00 x incoming, launch 2-3 degrees below horizontal, the contact lasts 7 ms and the ball slides 1-2.5 cm
    down the incline; landing 0.44 m from the wedge axis at drop height 0.5 m, 0.83 m at 1.0 m and 1.07 m at 1.5 m,
    in direction ``wedge_yaw`` within 0.001 rad. Every sampled context is solvable: a grid + compass search over
    the real simulator reached reward >= 0.99 on 100 of 100 contexts (``--solvability 100``), >= 0.98 at the four
    corners of the goal region.
    The Panda (visual only) stands on a 0.5 m stand at (-0.5, 0.3) and holds the ball from the side: on the side
    table before an attempt, at the drop point for an action.
    """

    task_name = "bounce"
    object_name = "ball"
    action_dims = (
        ActionDim("wedge_yaw", -math.pi, math.pi, "rad", "yaw of the wedge (direction the ball bounces off to)"),
        ActionDim("drop_height", 0.5, 1.5, "m", "height of the ball's centre above the ground at release"),
    )
    end_rule = "landed"
    landing_height = assets.BALL_RADIUS + 0.01
    skill_chain = ("throw", "bounce", "throw")
    state_extra = ("wedge_x", "wedge_y", "impact_z")
    grip_half_width = assets.BALL_RADIUS   # the Panda's fingers close on the ball

    def build_scene(self, root):
        assets.add_table(root, SIDE_TABLE_XY[0] - SIDE_TABLE_HALF, SIDE_TABLE_XY[0] + SIDE_TABLE_HALF,
                         SIDE_TABLE_XY[1] - SIDE_TABLE_HALF, SIDE_TABLE_XY[1] + SIDE_TABLE_HALF,
                         height=SIDE_TABLE_HEIGHT, name="side_table")
        assets.add_wedge(root)
        assets.add_ball(root)
        assets.add_goal_box(root)
        if self.with_panda:   # the Panda's stand: visual only, in the Panda's geom group (hidden from the obs camera)
            root.worldbody.add("geom", name="panda_stand", type="box", group=4, rgba=(0.35, 0.35, 0.38, 1),
                               pos=(PANDA_BASE[0], PANDA_BASE[1], PANDA_BASE[2] / 2),
                               size=(PANDA_STAND_HALF, PANDA_STAND_HALF, PANDA_BASE[2] / 2), **assets.GHOST)
        assets.add_camera(root, "obs", pos=(0.0, -1.2, 2.6), lookat=(0.0, -0.12, 0.3), fovy=46)
        assets.add_camera(root, "view", pos=(1.7, -1.9, 1.7), lookat=(0.0, -0.1, 0.55), fovy=50)

    def _init_ids(self):
        super()._init_ids()
        self._wedge = self.body_id("wedge")

    def sample_context(self, rng):
        while True:
            x = rng.uniform(*GOAL_X)
            y = rng.uniform(*GOAL_Y)
            if abs(x) > GOAL_MIN_ABS and abs(y) > GOAL_MIN_ABS:
                return {"goal": np.array([x, y])}

    def reset_scene(self, context):
        self.set_body_pose(self._wedge, WEDGE_POS, yaw=WEDGE_NEUTRAL_YAW)
        self.set_object_pose(BALL_START)

    def apply_action(self, action):
        yaw, height = action
        self.set_body_pose(self._wedge, WEDGE_POS, yaw=yaw)
        self.set_object_pose((DROP_XY[0], DROP_XY[1], height))

    def task_state(self):
        return [DROP_XY[0], DROP_XY[1], assets.WEDGE_IMPACT_Z]

    def panda_placement(self):
        return {"base_pos": PANDA_BASE, "base_yaw": PANDA_YAW}

    def hand_axes(self, action):
        """The Panda's grasp (approach, closing) for ``hand_target(action)``: horizontal, from the robot's side.

        A top-down grasp cannot reach drop heights above ~1.3 m; approaching horizontally along the line from the
        base to the ball reaches all of them.
        """
        t = self.hand_target(action)
        h = t[:2] - np.asarray(PANDA_BASE[:2])
        h = h / np.linalg.norm(h)
        return np.array([h[0], h[1], 0.0]), np.array([-h[1], h[0], 0.0])

    def hand_target(self, action):
        """Before an attempt the hand holds the ball on the side table; for ``action`` its drop point."""
        if action is None:
            return BALL_START.copy()
        return np.array([DROP_XY[0], DROP_XY[1], float(action[1])])

    # --- skill chain (issue 6): the PhyPlan agent's prediction of where the ball lands -------------------------------
    @staticmethod
    def skill_rollout(state, actions, skills):
        """Predicted landing xy of the ball for a batch of actions, from learnt skills: throw -> bounce -> throw.

        Args:
            state: the state observation as a torch tensor ``(n_state,)`` (names in ``env.state_names``).
            actions: ``(N, 2)`` float32 tensor of ``(wedge_yaw, drop_height)``.
            skills: an object with skill models ``throw`` and ``bounce`` (see :mod:`phyplan_agents.skills`).

        Returns:
            ``(N, 2)`` predicted xy (m) where the ball's centre falls through ``landing_height``.

        The ball falls from rest at ``drop_height`` to ``impact_z`` (throw with zero initial velocity: the vertical
        speed there); it bounces off the incline (bounce: the incline's nominal restitution, ``WEDGE_ANGLE``, the
        incoming vertical speed, no horizontal speed), and flies from the impact point above the wedge's yaw axis
        along ``wedge_yaw`` (throw from ``impact_z`` down to ``landing_height``).
        """
        import torch  # imported here: the envs themselves do not need torch

        from phyplan_agents.phyplan import queries as q
        from phyplan_envs.skill_scenes import restitution_of_solref

        yaw, height = actions[:, 0], actions[:, 1]
        wedge_xy, impact_z = state[5:7], state[7]             # wedge_x, wedge_y, impact_z
        zero = torch.zeros_like(yaw)
        fall = q.throw_landing(skills.throw, zero, zero, height - impact_z)
        e = torch.full_like(yaw, restitution_of_solref(assets.ELASTIC_SOLREF))
        out = skills.bounce.predict(torch.stack([e, torch.full_like(yaw, assets.WEDGE_ANGLE), fall.y[:, 2], zero],
                                                dim=1))
        reach = q.throw_landing(skills.throw, out[:, 1], out[:, 0], impact_z - BounceEnv.landing_height).y[:, 0]
        return wedge_xy + reach[:, None] * torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)


# ====================================================================================== measurement script (private)
def _measure_bounce(env: BounceEnv, yaw: float, height: float) -> dict[str, float]:
    """One drop stepped one physics step at a time: restitution and launch of the ball-incline contact, landing.

    ``restitution`` is the ratio of the normal velocity components (incline normal) just after and just before the
    contact; ``speed_ratio`` the same for the speed; ``elevation`` the launch angle above horizontal (deg).
    """
    import mujoco

    env.reset(seed=0)
    env.apply_action(np.array([yaw, height]))
    m, d = env.model, env.data
    mujoco.mj_forward(m, d)
    n = np.array([math.cos(yaw), math.sin(yaw), 1.0]) / math.sqrt(2)
    v_in = v_out = p_out = None
    t_in = t_out = 0
    prev = env.object_pos()
    for t in range(int(assets.MAX_SIM_TIME / m.opt.timestep)):
        v_before = env.object_vel()
        mujoco.mj_step(m, d)
        if v_in is None and d.ncon > 0:
            v_in, t_in = v_before, t
        elif v_in is not None and v_out is None and d.ncon == 0:
            v_out, t_out, p_out = env.object_vel(), t, env.object_pos()
        pos = env.object_pos()
        if pos[2] <= env.landing_height < prev[2]:
            f = (prev[2] - env.landing_height) / (prev[2] - pos[2])
            land = prev + f * (pos - prev)
            break
        prev = pos
    else:
        raise RuntimeError(f"the ball did not land (yaw {yaw}, height {height})")
    if v_in is None or v_out is None:
        raise RuntimeError(f"the ball never left the incline (yaw {yaw}, height {height})")
    env._needs_reset = True
    horiz = math.hypot(v_out[0], v_out[1])
    return {
        "restitution": float(-np.dot(v_out, n) / np.dot(v_in, n)),
        "speed_ratio": float(np.linalg.norm(v_out) / np.linalg.norm(v_in)),
        "elevation_deg": math.degrees(math.atan2(v_out[2], horiz)),
        "contact_ms": (t_out - t_in) * m.opt.timestep * 1000,
        "slide_m": float(np.linalg.norm(p_out[:2] - DROP_XY)),
        "range_m": float(np.linalg.norm(land[:2] - DROP_XY)),
        "direction_err_rad": float(abs(math.remainder(math.atan2(land[1] - DROP_XY[1], land[0] - DROP_XY[0]) - yaw,
                                                      2 * math.pi))),
    }


def _wrap(yaw: float) -> float:
    return math.remainder(yaw, 2 * math.pi)


def _best_action(env: BounceEnv, context, n_yaw: int = 36, n_height: int = 11, refine_calls: int = 80,
                 target: float = 0.99) -> tuple[np.ndarray, float, int]:
    """Grid search over (yaw, height) with the real simulator, then a compass search around the best grid point.

    Returns (best action, its reward, simulator calls). Stops early once the reward reaches ``target``.
    """
    lo, hi = env._low64, env._high64
    calls = 0

    def reward(a):
        nonlocal calls
        calls += 1
        env.reset(options={"context": context})
        return env.step(a)[1]

    best_a, best_r = None, -math.inf
    for yaw in np.linspace(-math.pi, math.pi, n_yaw, endpoint=False):
        for h in np.linspace(lo[1], hi[1], n_height):
            r = reward(np.array([yaw, h]))
            if r > best_r:
                best_a, best_r = np.array([yaw, h]), r
    step = np.array([math.pi / n_yaw, (hi[1] - lo[1]) / (n_height - 1) / 2])
    used = 0
    while used < refine_calls and best_r < target and step[0] > 1e-5:
        improved = False
        for k in range(2):
            for s in (1.0, -1.0):
                a = best_a.copy()
                a[k] += s * step[k]
                a[0] = _wrap(a[0])
                a[1] = min(max(a[1], lo[1]), hi[1])
                r = reward(a)
                used += 1
                if r > best_r:
                    best_a, best_r, improved = a, r, True
        if not improved:
            step /= 2
    return best_a, float(best_r), calls


def _main(argv=None) -> None:
    import argparse
    import statistics
    import time

    p = argparse.ArgumentParser(prog="python -m phyplan_envs.tasks.bounce",
                                description="Measure the Bounce task: restitution/landing and solvability.")
    p.add_argument("--measure", action="store_true", help="restitution and landing range per drop height")
    p.add_argument("--solvability", type=int, default=0, metavar="N", help="grid + refinement on N contexts")
    p.add_argument("--seed", type=int, default=0, help="first context seed (contexts use seeds seed..seed+N-1)")
    p.add_argument("--time", type=int, default=0, metavar="N", help="median wall time of N random episodes")
    args = p.parse_args(argv)
    env = BounceEnv()
    if args.measure:
        for h in (0.5, 0.75, 1.0, 1.25, 1.5):
            rows = [_measure_bounce(env, yaw, h) for yaw in (-2.5, -1.0, 0.0, 1.5, 3.0)]
            agg = {k: (min(r[k] for r in rows), max(r[k] for r in rows)) for k in rows[0]}
            print(f"drop {h:.2f} m: " + ", ".join(f"{k} {a:.4g}..{b:.4g}" for k, (a, b) in agg.items()))
    if args.solvability:
        best, calls = [], []
        for i in range(args.solvability):
            env.reset(seed=args.seed + i)
            ctx = env.context
            a, r, c = _best_action(env, ctx)
            best.append(r)
            calls.append(c)
            print(f"context seed {args.seed + i}: goal {np.round(ctx['goal'], 3).tolist()} best reward {r:.4f} "
                  f"at yaw {a[0]:.4f} rad, height {a[1]:.4f} m ({c} calls)")
        best = np.array(best)
        print(f"solvable (best reward >= 0.95): {np.mean(best >= 0.95):.1%} of {len(best)} contexts; "
              f"best reward min {best.min():.4f}, median {np.median(best):.4f}; "
              f"simulator calls per context median {statistics.median(calls)}")
    if args.time:
        rng = np.random.default_rng(0)
        times = []
        for i in range(args.time):
            a = env._low64 + (env._high64 - env._low64) * rng.random(2)
            t0 = time.perf_counter()
            env.reset(seed=i)
            env.step(a)
            times.append(time.perf_counter() - t0)
        print(f"episode wall time (reset + step, state obs): median {statistics.median(times) * 1000:.2f} ms "
              f"over {args.time} random episodes")


if __name__ == "__main__":
    _main()
