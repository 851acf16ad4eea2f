"""The shared contextual-bandit env: scene compilation, reset/step, the end rule, rewards and observations.

A task is one short subclass (see ``phyplan_envs/tasks/``) that declares:

* ``task_name``, ``object_name`` (the moving object), ``action_dims`` (named bounds in physical units),
* ``end_rule`` (``"landed"``: the object's centre falls below ``landing_height``; ``"rest"``: it moved and stopped),
* ``facts`` (the task's physical facts as data: masses, heights, radii, ...) and ``state_extra`` (extra state entries),
* ``build_scene(root)``, ``sample_context(rng)``, ``reset_scene(context)`` and ``apply_action(action)``.

Reset/step, rewards and observations live here once; the end rule's stepping loop in :mod:`phyplan_envs.end_rule`,
the spaces and input checks in :mod:`phyplan_envs.spaces`, the renderers in :mod:`phyplan_envs.rendering`, the Panda
in :mod:`phyplan_envs.panda` and its task hooks in :mod:`phyplan_envs.robot_hooks`.

One episode is one attempt: ``reset`` samples (or restores) the context and returns its observation; ``step(action)``
sets the tools, releases the object, simulates until the end rule fires or ``MAX_SIM_TIME`` passes, and returns
``reward = 1 - d_final / d_initial`` with ``terminated=True``; d is the xy distance from the object to the goal centre.

Extending the env (one method per stage, each called from one place; override and call ``super()``):

* ``_build()``: the MJCF scene (arena, task pieces, Panda) compiled into ``physics``/``model``/``data``;
* ``_reset_physics(context)``: the simulator state for a context (``mj_resetData``, goal, ``reset_scene``);
* ``_execute(action)``: the attempt's set-up and release (default: ``apply_action`` puts tools and object in place);
* ``_simulate()``: physics until the end rule fires; ``_outcome(result)``: reward and ``info`` of the attempt;
* ``_observation(object_pos)``: the observation of the current context; ``reset_options``: the accepted options.
"""
from __future__ import annotations

from . import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import math
from typing import Any, Mapping

import gymnasium as gym
import mujoco
import numpy as np
from dm_control import mjcf

from . import assets
from .camera import DepthView
from .end_rule import simulate_until_end
from .rendering import CameraView
# OBS_MODES, STATE_BOUND and ActionDim are also re-exported from here (tasks import ActionDim from base)
from .spaces import (GOAL_BOUND, MIN_GOAL_DISTANCE, OBS_MODES, STATE_BOUND, ActionDim,  # noqa: F401
                     action_space, check_action, check_context, check_env_args, check_flag, check_goal,
                     check_reset_options, check_seed, copy_context, observation_space)
from . import compiled
from .pickling import Rebuildable
from .robot_hooks import RobotHooks
from .scene_access import SceneAccess
from .spaces import ContextChecks, format_xy as _xy

# The Panda's geom group (phyplan_envs.panda.PANDA_GEOM_GROUP; Bounce's Panda stand uses it too): drawn by render(),
# hidden from the observation camera.
ROBOT_GEOM_GROUP = 4


class PhyPlanEnv(RobotHooks, SceneAccess, ContextChecks, Rebuildable, gym.Env):
    """Base class of the four phyplan tasks. Not registered itself; see the task subclasses.

    Args:
        obs_mode: ``"state"`` (float32 vector, see ``state_names``), ``"image"`` (uint8 H x W x 3 from the fixed
            ``obs`` camera), ``"state_image"`` (a Dict with keys ``"state"`` and ``"image"``) or ``"rgbd"`` (a Dict
            with ``"rgb"``, the image, and ``"depth"``, float32 z-depth in metres; see :mod:`phyplan_envs.camera`
            and :meth:`camera_model`).
        image_size: height and width of the image observation (default 128).
        render_mode: ``None`` or ``"rgb_array"`` (a 480 x 480 frame of the whole scene, Panda included).
        clip_actions: if true, out-of-bounds actions are clipped to the bounds (and ``info["clipped"]`` says so);
            by default they raise ``ValueError``. NaN, inf and wrong shapes always raise.
        record_trajectory: if true, ``info["trajectory"]`` holds the moving object's path as rows
            ``(t, x, y, z)`` sampled every ``chunk`` physics steps. Also per episode via
            ``reset(options={"record_trajectory": True})``.
        with_panda: include the Franka Panda (visual only: it collides with nothing and has no joints in the
            physics model, so it costs no stepping time). Default true.
        robot: ``None`` (default: the kinematic mode, tools and object placed directly) or ``"panda"`` (robot
            mode: the scene holds the articulated Panda, which executes every attempt; ``info`` then reports
            ``robot_ok`` and ``robot_reason``; see :mod:`phyplan_envs.panda.robot` and docs/robot.md).
        ``render_mode="rgb_array_list"``: ``render()`` after ``step`` returns every frame of the attempt (set-up,
        release, flight) at ``metadata["render_fps"]``; see :mod:`phyplan_envs.video`.

    Inputs: every argument, reset option, seed and action is checked where it enters (``TypeError`` for a wrong
    type, ``ValueError`` for a bad value, naming it; :mod:`phyplan_envs.spaces`). A goal (``options["goal"]``, a
    context's or a sampled one) must lie in :attr:`goal_region` and at least :attr:`min_goal_distance` from the
    object's start; a context passed back may hold only :attr:`context_keys`. After :meth:`close` the env raises
    ``RuntimeError``.
    """

    metadata = {"render_modes": ["rgb_array", "rgb_array_list"], "render_fps": 30}
    reset_options: tuple[str, ...] = ("context", "goal", "record_trajectory")

    # --- declared by each task -------------------------------------------------------------------------------------
    task_name: str = ""
    object_name: str = "ball"
    action_dims: tuple[ActionDim, ...] = ()
    end_rule: str = "landed"
    landing_height: float = assets.BALL_RADIUS + 0.01
    facts: Any = None      # a frozen dataclass of the task's physical facts, read by its scene and by agents' models
    state_extra: tuple[str, ...] = ()
    goal_walls: bool = True
    robot_bodies: tuple[str, ...] = ()     # robot mode: the bodies the arm may grasp (see robot_plan)
    robot_latches: tuple[str, ...] = ()    # robot mode: the tool joints the arm may turn (added by robot_scene)
    # The goal's space, checked at every reset (check_goal_region): inside goal_region (x range, y range; default the
    # 12 x 12 m arena floor) and at least min_goal_distance from the object's start in xy (reward = 1 - d/d0).
    goal_region: tuple[tuple[float, float], tuple[float, float]] = ((-GOAL_BOUND, GOAL_BOUND), (-GOAL_BOUND, GOAL_BOUND))
    min_goal_distance: float = MIN_GOAL_DISTANCE
    # The entries of a context; a task that adds entries declares them here and checks them in check_context_entry.
    context_keys: tuple[str, ...] = ("goal",)
    _closed: bool = False

    # --- engine settings shared by all tasks --------------------------------------------------------------------------
    chunk: int = 5                 # physics steps between end-rule checks (5 ms)
    rest_speed: float = 0.01       # m/s: "at rest" below this object speed
    rest_min_time: float = 0.6     # s: the rest rule never fires before this (the pendulum needs ~0.3 s to swing down)
    render_size: int = 480
    _flight_watch = None           # robot mode's arm-free flight: a check per chunk (phyplan_envs.panda.flight)

    def __init__(self, obs_mode: str = "state", image_size: int = 128, render_mode: str | None = None,
                 clip_actions: bool = False, record_trajectory: bool = False, with_panda: bool = True,
                 robot: str | None = None):
        self.image_size = check_env_args(obs_mode, render_mode, image_size, clip_actions=clip_actions,
                                         record_trajectory=record_trajectory, with_panda=with_panda)
        if robot is not None and not isinstance(robot, str):
            raise TypeError(f"robot must be None (kinematic mode) or 'panda', got {type(robot).__name__} {robot!r}")
        if robot not in (None, "panda"):
            raise ValueError(f"robot must be None (kinematic mode) or 'panda', got {robot!r}")
        if robot is not None and not with_panda:
            raise ValueError("robot='panda' needs the Panda in the scene: do not pass with_panda=False with it")
        self.robot = robot
        self.obs_mode = obs_mode
        self.render_mode = render_mode
        self.clip_actions = bool(clip_actions)
        self.record_trajectory = bool(record_trajectory)
        self.with_panda = bool(with_panda)
        self._build()

        self.action_space = action_space(self.action_dims)
        self._low64 = np.array([d.low for d in self.action_dims], dtype=np.float64)
        self._high64 = np.array([d.high for d in self.action_dims], dtype=np.float64)
        self.observation_space = observation_space(obs_mode, len(self.state_names), self.image_size)
        # The observation camera shows the task (goal, object, tools) and hides the Panda; render() frames show it.
        self._obs_view = CameraView(self.model, self._cam_obs, self.image_size, self.image_size,
                                    {ROBOT_GEOM_GROUP: False})
        self._frame_view = CameraView(self.model, self._cam_view, self.render_size, self.render_size,
                                      {ROBOT_GEOM_GROUP: True})
        self._depth_view = DepthView(self.model, self._cam_obs, self.image_size, self.image_size,
                                     {ROBOT_GEOM_GROUP: False})   # rgbd mode only (opens at its first draw)
        self._frames = None      # rgb_array_list: the frames of the current attempt
        if render_mode == "rgb_array_list":
            from .video import AttemptFrames
            self._frames = AttemptFrames(self._frame_view, self.metadata["render_fps"])
        self._robot_report = None
        self._robot_ready = None
        self._flight = None      # robot mode: the flight without the arm (phyplan_envs.panda.flight)
        if self._robot is not None:
            from .panda.flight import ArmFreeFlight
            self._flight = ArmFreeFlight(self)

        self._context: dict[str, Any] | None = None
        self._needs_reset = True
        self._last_action: np.ndarray | None = None
        self._episode_record = False

    # ======================================================================================== to be declared by tasks
    def build_scene(self, root: mjcf.RootElement) -> None:
        """Add the task's pieces (see :mod:`phyplan_envs.assets`) to ``root``; must add ``object_name``, ``goal``."""
        raise NotImplementedError(f"{type(self).__name__} must implement build_scene")

    def sample_context(self, rng: np.random.Generator) -> dict[str, Any]:
        """A new context drawn with ``rng``: at least ``{"goal": [x, y]}``."""
        raise NotImplementedError(f"{type(self).__name__} must implement sample_context")

    def reset_scene(self, context: Mapping[str, Any]) -> None:
        """Place the object at its start for ``context`` (called after ``mj_resetData`` and the goal placement)."""
        raise NotImplementedError(f"{type(self).__name__} must implement reset_scene")

    def apply_action(self, action: np.ndarray) -> None:
        """Set the tools for ``action`` (validated, float64) and put the object at its release state."""
        raise NotImplementedError(f"{type(self).__name__} must implement apply_action")

    def task_state(self) -> list[float]:
        """The values of ``state_extra`` for the current context."""
        return []

    # ============================================================================================ public properties
    @property
    def action_names(self) -> tuple[str, ...]:
        return tuple(d.name for d in self.action_dims)

    @property
    def state_names(self) -> tuple[str, ...]:
        return ("goal_x", "goal_y", "object_x", "object_y", "object_z") + tuple(self.state_extra)

    @property
    def context(self) -> dict[str, Any]:
        """The current context (a copy), to pass back as ``reset(options={"context": ...})``."""
        if self._context is None:
            raise RuntimeError("call reset() before reading the context")
        return copy_context(self._context)

    # ==================================================================================================== building
    def _build(self) -> None:
        """Build the MJCF scene (arena, ``build_scene``, the Panda), compile it and look up the named parts."""
        root = assets.arena(self.task_name or "phyplan")
        self.build_scene(root)
        self._panda = None
        self._robot = None
        if self.robot is not None:
            from .panda.robot import attach_robot
            self.robot_scene(root)
            place = self.robot_placement()
            hold = None if self.object_name in self.robot_bodies else self.object_name   # still until released
            self._robot = attach_robot(root, place["base_pos"], place["base_yaw"], self.robot_bodies,
                                       self.robot_latches, hold)
        elif self.with_panda:
            from .panda import attach_panda
            self._panda = attach_panda(root, **self.panda_placement())
        self.mjcf_model = root
        self.physics = compiled.compile_scene(root)     # a copy of the process's compiled scene (same bytes)
        self.model: mujoco.MjModel = self.physics.model.ptr
        self.data: mujoco.MjData = self.physics.data.ptr
        if self._panda is not None:
            self._panda.bind(self.physics)
        if self._robot is not None:
            self._robot.bind(self.physics)
        self._init_ids()

    # ======================================================================================================= API
    def reset(self, *, seed: int | None = None, options: Mapping[str, Any] | None = None):
        self._check_open("reset")
        seed = check_seed(seed)
        options = check_reset_options(options, self.reset_options)
        given = goal = None
        if options.get("context") is not None:
            given = check_context(options["context"], self.context_keys, self.check_context_entry)
        if options.get("goal") is not None:
            goal = check_goal(options["goal"], "options['goal']")
        record = options.get("record_trajectory")
        record = self.record_trajectory if record is None else check_flag(record, "options['record_trajectory']")
        super().reset(seed=seed)
        context = given if given is not None else self.sample_context(self.np_random)
        what = ("options['goal']" if goal is not None else
                "options['context']['goal']" if given is not None else f"{self.task_name}: the sampled goal")
        if goal is not None:
            context["goal"] = goal
        context["goal"] = np.asarray(context["goal"], dtype=np.float64)
        self.check_goal_region(context["goal"], what)
        self._context = context
        self._episode_record = record

        self._reset_physics(context)
        self._start_pos = self.object_pos()
        self._d0 = float(np.linalg.norm(self._start_pos[:2] - context["goal"]))
        if not self._d0 >= self.min_goal_distance:
            self._context, self._needs_reset = None, True      # a failed reset leaves no usable episode
            raise ValueError(f"{what} = {_xy(context['goal'])} is {self._d0:.3g} m from the {self.object_name}'s "
                             f"start {_xy(self._start_pos[:2])}; goals must be at least {self.min_goal_distance} m "
                             f"from it (the reward 1 - d/d0 divides by that distance)")
        self._needs_reset = False
        self._last_action = None
        if self._frames is not None:
            if self._panda is not None:
                self._panda.pose_for(self, None)     # the arm as render() shows it before an attempt
                mujoco.mj_kinematics(self.model, self.data)
            self._frames.reset(self.data)
        info = {"goal": context["goal"].copy(), "object_pos": self._start_pos.copy(),
                "initial_distance": self._d0, "context": self.context}
        return self._observation(), info

    def step(self, action):
        self._check_open("step")
        if self._needs_reset:
            raise RuntimeError(f"{self.task_name}: one episode is one attempt; call reset() before step() again")
        action, clipped = check_action(action, self.action_dims, self._low64, self._high64, self.clip_actions,
                                       self.task_name)
        self._last_action = action
        self._execute(action)
        result = self._simulate()
        self._needs_reset = True
        if self._frames is not None:
            if self._flight is not None and self._flight.flew:
                self._flight.replay(self._frames, result["n_steps"])
            else:
                self._frames.flight(self.model, self._release_state, result["n_steps"])
        reward, info = self._outcome(result)
        info.update(action=action.copy(), clipped=clipped, context=self.context)
        if self._robot is not None:
            info.update(self._robot_report.info(), robot_arm_free=self._flight.flew)
        if self._episode_record:
            info["trajectory"] = result["trajectory"]
        obs = self._observation(object_pos=result["final_pos"])
        return obs, reward, True, False, info

    def render(self):
        self._check_open("render")
        if self.render_mode == "rgb_array_list":
            if self._context is None:
                raise RuntimeError("call reset() before render()")
            return list(self._frames.frames)     # this episode's frames so far (kept until the next reset)
        if self.render_mode != "rgb_array":
            return None
        if self._context is None:
            raise RuntimeError("call reset() before render()")
        if self._panda is not None:
            self._panda.pose_for(self, self._last_action)
        mujoco.mj_forward(self.model, self.data)
        return self._frame_view.draw(self.data)

    def close(self):
        """Free the renderers and the compiled model now (with the Panda ~23 MB of MuJoCo buffers); afterwards
        ``reset``, ``step`` and ``render`` raise ``RuntimeError``. Closing again does nothing."""
        for name in ("_obs_view", "_frame_view", "_depth_view"):
            view = getattr(self, name, None)
            if view is not None:
                view.close()
        if getattr(self, "_flight", None) is not None:
            self._flight.close()
        physics = getattr(self, "physics", None)
        for name in _RELEASED_ON_CLOSE:           # everything that holds the model or data
            if name in self.__dict__:
                setattr(self, name, None)
        self._closed = True
        compiled.release(physics)
        super().close()

    def _check_open(self, what: str) -> None:
        if self._closed:
            raise RuntimeError(f"{self.task_name}: {what}() after close(): the env is closed (its model is freed); "
                               "make a new env")

    # ============================================================================================ the attempt's stages
    def _reset_physics(self, context: Mapping[str, Any]) -> None:
        """The simulator state for ``context``: reset data, goal placed, the task's start (``reset_scene``)."""
        mujoco.mj_resetData(self.model, self.data)
        goal_z = self.model.body_pos[self._goal_body][2]
        self.set_body_pose(self._goal_body, (context["goal"][0], context["goal"][1], goal_z))
        self.reset_scene(context)
        if self._robot is not None:
            if self._robot_ready is None:     # once: the arm waits above its first grasp for the middle action
                self._robot.ready_towards(self.object_pos())
                mujoco.mj_kinematics(self.model, self.data)
                self._robot_ready = self._robot.ready_above(self.robot_plan((self._low64 + self._high64) / 2)[0])
                self.reset_scene(context)
            self._robot.reset()
            self._flight.reset(context)
        mujoco.mj_forward(self.model, self.data)

    def _execute(self, action: np.ndarray) -> None:
        """Set up and release the attempt ``action`` (validated, float64): the tools and object put in place
        (kinematic mode), or the arm executing ``robot_plan(action)`` (robot mode)."""
        frames = self._frames
        if self._robot is not None:
            tick = None if frames is None else (lambda clock: frames.setup_tick(self.data, clock))
            self._robot_report = self._robot.execute(self.robot_plan(action), on_frame=tick)
        else:
            self.apply_action(action)
            if frames is not None and self._panda is not None:
                q_from = self._panda.q.copy()                  # the pose drawn at reset
                q_to = self._panda.pose_for(self, action).q    # the release pose (visual geoms only)
                frames.kinematic_setup(self.model, self.data, self._panda, q_from, q_to, self._panda.finger_opening)
        mujoco.mj_forward(self.model, self.data)
        if frames is not None:
            self._release_state = frames.release_state(self.model, self.data)

    def _simulate(self) -> dict[str, Any]:
        """Step the physics from the released state until the end rule fires or ``MAX_SIM_TIME`` passes
        (:func:`phyplan_envs.end_rule.simulate_until_end`)."""
        if self._flight is not None:      # robot mode: in the kinematic scene unless the arm may touch something
            out = self._flight.run()
            if out is not None:
                return out
        return simulate_until_end(self)

    def _outcome(self, result: Mapping[str, Any]) -> tuple[float, dict[str, Any]]:
        """The reward and ``info`` of an attempt that ended as ``result`` (from :meth:`_simulate`)."""
        final = result["final_pos"]
        goal = self._context["goal"]
        d = float(np.linalg.norm(final[:2] - goal))
        reward = 1.0 - d / self._d0
        in_box = bool(np.all(np.abs(final[:2] - goal) <= assets.GOAL_HALF))
        info = {"goal": goal.copy(), "final_pos": final, "distance": d, "initial_distance": self._d0,
                "is_success": in_box, "sim_time": result["sim_time"], "n_steps": result["n_steps"],
                "end_reason": result["end_reason"]}
        return float(reward), info

    # =============================================================================================== observations
    def _state_vector(self, object_pos: np.ndarray | None = None) -> np.ndarray:
        p = self._start_pos if object_pos is None else object_pos
        g = self._context["goal"]
        return np.array([g[0], g[1], p[0], p[1], p[2], *self.task_state()], dtype=np.float32)

    def _observation(self, object_pos: np.ndarray | None = None):
        """The observation in ``obs_mode``; the state shows ``object_pos`` (default: the start position)."""
        if self.obs_mode == "state":
            return self._state_vector(object_pos)
        if self.obs_mode == "image":
            return self._obs_view.draw(self.data)
        if self.obs_mode == "rgbd":
            return {"rgb": self._obs_view.draw(self.data), "depth": self._depth_view.draw(self.data)}
        return {"state": self._state_vector(object_pos), "image": self._obs_view.draw(self.data)}


# The attributes close() drops (each holds the model, the data or the MJCF tree).
_RELEASED_ON_CLOSE = ("physics", "model", "data", "mjcf_model", "_panda", "_robot", "_obs_view", "_frame_view",
                      "_depth_view", "_frames", "_flight")


def polar(distance: float, angle: float) -> np.ndarray:
    """The xy point at ``distance`` along direction ``angle`` (radians from +x)."""
    return np.array([distance * math.cos(angle), distance * math.sin(angle)])
