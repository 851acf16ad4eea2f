"""How an attempt is carried out: the executor an env holds, picked by the ``robot`` argument (ManiSkill's style:
the task never branches on the robot).

Both executors have one small interface, which :class:`phyplan_envs.base.PhyPlanEnv` calls from one place each:

* ``attach(root)`` before compiling (the arm's MJCF: none, the visual Panda, or the articulated one) and
  ``bind(physics)`` after;
* ``reset(context, physics)`` at the end of every reset's scene set-up (``physics``: the varied task's hidden
  values passed to this reset, or ``None``);
* ``execute(action, frames)``: the set-up and release; ``simulate(record)``: the flight until the end rule fires
  (:func:`phyplan_envs.end_rule.simulate_until_end`); ``info()``: the executor's entries of the step's ``info``;
* ``pose_arm(action)``: the arm as ``render()`` draws it; ``draw_flight(frames, n_steps)``: the flight's video
  frames; ``close()``.

:class:`KinematicExecutor` (``robot=None``) puts the tools and the object in place (``env.apply_action``) and poses
the visual Panda (:mod:`phyplan_envs.panda`). :class:`RobotExecutor` (``robot="panda"``) has the articulated Panda
carry out ``env.robot_plan(action)`` (:mod:`phyplan_envs.panda.robot`) and flies the object in a kinematic twin of
the env (:mod:`phyplan_envs.panda.robot.flight`).

Stage timing: when ``env.stage_timer`` is a callable, each stage calls ``stage_timer(stage, seconds, steps)`` with
the CPU seconds (``time.process_time``) it took: ``"setup"`` (the set-up and release), ``"flight"`` (from the env),
and in robot mode ``"plan"`` (``robot_plan``), ``"ik"`` (every IK solve of the arm) and ``"setup_physics"`` (the
arm controller's physics steps; ``steps`` counts them).
"""
from __future__ import annotations

import time

import mujoco

from .end_rule import simulate_until_end


def timed(timer, stage: str, f, *args, **kwargs):
    """``f(*args, **kwargs)``, its CPU time reported to ``timer(stage, seconds, 0)`` if ``timer`` is set."""
    if timer is None:
        return f(*args, **kwargs)
    t = time.process_time()
    try:
        return f(*args, **kwargs)
    finally:
        timer(stage, time.process_time() - t, 0)


def timed_step(timer):
    """``mujoco.mj_step`` reporting each call's CPU time and steps to ``timer`` as ``"setup_physics"``."""
    def step(m, d, nstep=1):
        t = time.process_time()
        mujoco.mj_step(m, d, nstep=nstep)
        timer("setup_physics", time.process_time() - t, nstep)
    return step


class KinematicExecutor:
    """Kinematic mode: the tools and the object are put in place directly; the Panda (``with_panda``) is a posed
    visual arm that touches nothing."""

    def __init__(self, env):
        self.env = env
        self.panda = None              # the visual Panda (phyplan_envs.panda.PandaHandle)
        self.release_state = None      # rgb_array_list: the state the flight's frames are replayed from

    def attach(self, root) -> None:
        if self.env.with_panda:
            from .panda import attach_panda

            pos, yaw = self.env.panda_base
            self.panda = attach_panda(root, pos, yaw)

    def bind(self, physics) -> None:
        if self.panda is not None:
            self.panda.bind(physics)

    def reset(self, context, physics=None) -> None:
        """Nothing to do: the scene is set up."""

    def pose_arm(self, action) -> bool:
        """Pose the visual arm as holding ``action``'s release (``None``: before an attempt); False without it."""
        if self.panda is None:
            return False
        self.panda.pose_for(self.env, action)
        return True

    def execute(self, action, frames) -> None:
        env = self.env
        timed(env.stage_timer, "setup", env.apply_action, action)
        if frames is not None and self.panda is not None:
            q_from = self.panda.q.copy()                       # the pose drawn at reset
            q_to = self.panda.pose_for(env, action).q         # the release pose (visual geoms only)
            frames.kinematic_setup(env.model, env.data, self.panda, q_from, q_to, self.panda.finger_opening)
        mujoco.mj_forward(env.model, env.data)
        if frames is not None:
            self.release_state = frames.release_state(env.model, env.data)

    def simulate(self, record: bool) -> dict:
        return simulate_until_end(self.env, record=record)

    def draw_flight(self, frames, n_steps: int) -> None:
        frames.flight(self.env.model, self.release_state, n_steps)

    def info(self) -> dict:
        return {}

    def close(self) -> None:
        self.panda = None


class RobotExecutor(KinematicExecutor):
    """Robot mode: the articulated Panda executes every attempt (``info`` reports ``robot_ok``, ``robot_reason``,
    the set-up's figures and ``robot_arm_free``); the flight after the last release runs in a kinematic twin of the
    env unless the arm might touch something (:class:`phyplan_envs.panda.robot.flight.ArmFreeFlight`)."""

    def __init__(self, env):
        super().__init__(env)
        self.arm = None        # phyplan_envs.panda.robot.RobotArm
        self.flight = None     # phyplan_envs.panda.robot.flight.ArmFreeFlight
        self.ready = None      # whether the arm waits above its first grasp (set at the first reset)
        self.report = None     # the last attempt's phyplan_envs.panda.robot.RobotReport

    def attach(self, root) -> None:
        from .panda.robot import attach_robot

        env = self.env
        env.tools.robot_scene(root)
        bodies = env.tools.robot_bodies                                        # what the arm may grasp
        pos, yaw = env.robot_base or env.panda_base
        hold = None if env.object_name in bodies else env.object_name         # still until released
        self.arm = attach_robot(root, pos, yaw, bodies, env.tools.robot_latches, hold)

    def bind(self, physics) -> None:
        from .panda.robot.flight import ArmFreeFlight

        self.arm.bind(physics)
        self.flight = ArmFreeFlight(self.env.kinematic_twin(), self.arm, self.env.tools.robot_bodies)

    def reset(self, context, physics=None) -> None:
        env, arm = self.env, self.arm
        if self.ready is None:     # once: the arm waits above its first grasp for the middle action
            arm.ready_towards(env.object_pos())
            mujoco.mj_kinematics(env.model, env.data)
            self.ready = arm.ready_above(env.robot_plan((env.action_low + env.action_high) / 2)[0])
            env.reset_scene(context)
        arm.reset()
        self.flight.reset(context, physics)

    def pose_arm(self, action) -> bool:
        return False               # the arm is where the physics has it

    def execute(self, action, frames) -> None:
        env, arm = self.env, self.arm
        timer = arm.ik.timer = env.stage_timer
        arm.mj_step = mujoco.mj_step if timer is None else timed_step(timer)
        tick = None if frames is None else (lambda clock: frames.setup_tick(env.data, clock))
        plan = timed(timer, "plan", env.robot_plan, action)
        env.hidden.before_arm(action)
        self.report = timed(timer, "setup", arm.execute, plan, on_frame=tick)
        mujoco.mj_forward(env.model, env.data)
        if frames is not None:
            self.release_state = frames.release_state(env.model, env.data)
        if self.report.ok:
            env.hidden.after_arm(action)

    def simulate(self, record: bool) -> dict:
        out = self.flight.run(record, keep_release=self.env.render_mode == "rgb_array_list")
        return out if out is not None else simulate_until_end(self.env, record=record)

    def draw_flight(self, frames, n_steps: int) -> None:
        if self.flight.flew:
            self.flight.replay(frames, n_steps)
        else:
            super().draw_flight(frames, n_steps)

    def info(self) -> dict:
        return {**self.report.info(), "robot_arm_free": self.flight.flew}

    def close(self) -> None:
        if self.flight is not None:
            self.flight.close()
        self.flight = self.arm = None


EXECUTORS: dict[str | None, type[KinematicExecutor]] = {None: KinematicExecutor, "panda": RobotExecutor}
"""``robot`` argument -> the executor class."""


def executor_for(robot, with_panda: bool) -> type[KinematicExecutor]:
    """The executor class of the env argument ``robot`` (``with_panda``: the scene holds the Panda); a clear
    ``TypeError``/``ValueError`` for a bad one."""
    names = " or ".join(repr(k) for k in EXECUTORS if k is not None)
    if robot is not None and not isinstance(robot, str):
        raise TypeError(f"robot must be None (kinematic mode) or {names}, got {type(robot).__name__} {robot!r}")
    if robot not in EXECUTORS:
        raise ValueError(f"robot must be None (kinematic mode) or {names}, got {robot!r}")
    if robot is not None and not with_panda:
        raise ValueError(f"robot={robot!r} needs the Panda in the scene: do not pass with_panda=False with it")
    return EXECUTORS[robot]
