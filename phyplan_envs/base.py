"""The shared contextual-bandit env: the attempt's stages, rewards and observations, and the inspection API.

A task (``phyplan_envs/tasks/``) is an assembly of tools (:mod:`phyplan_envs.tools`) plus its facts: ``task_name``,
``object_name``, ``action_dims``, ``end_rule`` (``"landed"``: the object's centre falls below ``landing_height``;
``"rest"``: it moved and stopped), ``facts``, ``state_extra``/``task_state()``, ``cameras``, the Panda's stands
(``panda_base``, ``robot_base``), ``assemble()`` (its tools, in build order) and ``sample_goal(rng)``; a varied task
adds a hidden-physics component (``hidden_model``). The env holds the parts: ``scene`` (:mod:`phyplan_envs.scene`,
named access), ``tools`` (the assembly), ``executor`` (:mod:`phyplan_envs.execution`: kinematic or robot, by
``robot``), ``observer`` (:mod:`phyplan_envs.observation`) and ``hidden`` (:mod:`phyplan_envs.hidden_physics`).

One episode is one attempt: ``reset`` samples (or restores) the context (:mod:`phyplan_envs.context`: the reset's
inputs and the context's checks) and returns its observation; ``step(action)`` sets the tools, releases the object,
simulates until the end rule fires or ``MAX_SIM_TIME`` passes, and returns ``reward = 1 - d_final / d_initial`` with
``terminated=True``; d is the xy distance from the object to the goal centre.

Inspection API (for design checks, tests and analysis; none of it is needed to act):

* ``action_low``, ``action_high``: the action bounds as float64 (the Box is float32);
* ``release(action)``: set up and release the attempt as ``step`` would (either mode), without the flight; returns
  the object's :class:`ObjectState` (the episode is then used up: ``step`` needs a ``reset`` first);
* ``object_state()``, ``object_pos()``, ``object_vel()``: the moving object now; ``pendulum`` (the
  :class:`~phyplan_envs.tools.PendulumRig` where the task has one: ``hinge_dof``, ``hinge_angle()``,
  ``hinge_speed()``, ``pivot()``); ``timestep`` (the physics time step, s); ``model``/``data`` (MuJoCo);
* ``contact_pairs()`` (the geom names of the active contacts) and ``touching(geom1, geom2)``;
* ``true_camera_model()``: with ``camera_noise``, the ``obs`` camera where it really is in this context;
* ``stage_timer``: set it to a callable ``(stage, seconds, steps)`` to time the stages of every step (see
  :mod:`phyplan_envs.execution`: ``"setup"``, ``"flight"``, robot mode's ``"plan"``, ``"ik"``, ``"setup_physics"``).
"""
from __future__ import annotations

from . import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

from typing import Any, Mapping

import gymnasium as gym
import mujoco
import numpy as np

from . import assets
from . import camera_noise as cn
from . import compiled
from .camera import CameraModel
from .context import check_start_distance, episode_context, reset_inputs
from .end_rule import outcome
from .execution import executor_for, timed
from .observation import ROBOT_GEOM_GROUP, Observer  # noqa: F401  (ROBOT_GEOM_GROUP re-exported)
from .pickling import kinematic_twin, reduce_env
from .description import SceneDescription
from .scene import ObjectState, Scene
# OBS_MODES, STATE_BOUND and ActionDim are also re-exported from here (tasks import ActionDim from base)
from .spaces import (GOAL_BOUND, MIN_GOAL_DISTANCE, OBS_MODES, STATE_BOUND, ActionDim,  # noqa: F401
                     action_space, check_action, check_env_args, copy_context, observation_space)
from .tools import Assembly
from .tools.supports import polar  # noqa: F401  (re-exported)
from .hidden_physics import NoHiddenPhysics


class PhyPlanEnv(gym.Env):
    """Base class of the phyplan tasks. Not registered itself; see the task classes.

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
        physics_space: the varied tasks only (:mod:`phyplan_envs.hidden_physics`).
        camera_noise: ``None`` (default: the ideal camera), ``"default"`` or a dict of some noise parameters (the
            others default): the ``obs`` camera's pictures (``image``, ``state_image``, ``rgbd``) get pixel noise,
            depth noise and dropout, lighting jitter and a pose error drawn per context, while :meth:`camera_model`
            keeps the nominal calibration; see :mod:`phyplan_envs.camera_noise` (the model, the defaults, how a
            context's ``camera_noise_seed`` replays it). The state vector and outcomes do not change.
        ``render_mode="rgb_array_list"``: ``render()`` after ``step`` returns every frame of the attempt (set-up,
        release, flight) at ``metadata["render_fps"]``; see :mod:`phyplan_envs.video`.

    Inputs: every argument, reset option, seed and action is checked where it enters (``TypeError`` for a wrong
    type, ``ValueError`` for a bad value, naming it; :mod:`phyplan_envs.spaces`). A goal (``options["goal"]``, a
    context's or a sampled one) must lie in :attr:`goal_region` and at least :attr:`min_goal_distance` from the
    object's start; a context passed back may hold only :attr:`context_keys`. After :meth:`close` the env raises
    ``RuntimeError``.
    """

    metadata = {"render_modes": ["rgb_array", "rgb_array_list"], "render_fps": 30}

    # --- declared by each task -------------------------------------------------------------------------------------
    task_name: str = ""
    object_name: str = "ball"
    action_dims: tuple[ActionDim, ...] = ()
    end_rule: str = "landed"
    landing_height: float = assets.BALL_RADIUS + 0.01
    facts: Any = None      # a frozen dataclass of the task's physical facts, read by its scene and by agents' models
    state_extra: tuple[str, ...] = ()
    cameras: tuple[tuple[str, tuple, tuple, float], ...] = ()   # (name, pos, lookat, fovy): "obs" and "view"
    panda_base: tuple[tuple[float, float, float], float] = ((-0.55, -0.35, 0.0), 0.6)   # the Panda's (pos, yaw)
    robot_base: tuple[tuple[float, float, float], float] | None = None     # robot mode's stand; None: panda_base
    hidden_model: type = NoHiddenPhysics  # a varied task's hidden-physics component (phyplan_envs.hidden_physics)
    # The goal's space, checked at every reset (check_goal_region): inside goal_region (x range, y range; default the
    # 12 x 12 m arena floor) and at least min_goal_distance from the object's start in xy (reward = 1 - d/d0).
    goal_region: tuple[tuple[float, float], ...] = ((-GOAL_BOUND, GOAL_BOUND), (-GOAL_BOUND, GOAL_BOUND))
    min_goal_distance: float = MIN_GOAL_DISTANCE
    pendulum = None                # the task's PendulumRig, where it has one (set by assemble)
    hand_tool = None               # the tool the Panda's hand holds (hand_target, hand_axes)
    stage_timer = None             # inspection: a callable (stage, seconds, steps) timing each step's stages
    _closed: bool = False

    # --- engine settings shared by all tasks --------------------------------------------------------------------------
    timestep: float = assets.TIMESTEP   # s: the physics time step
    chunk: int = 5                 # physics steps between end-rule checks (5 ms)
    rest_speed: float = 0.01       # m/s: "at rest" below this object speed
    rest_min_time: float = 0.6     # s: the rest rule never fires before this (the pendulum needs ~0.3 s to swing down)
    max_sim_time: float = assets.MAX_SIM_TIME   # s: the episode cap (the end rule's "timeout")
    render_size: int = 480

    def __new__(cls, *args: Any, **kwargs: Any):
        env = super().__new__(cls)
        env._init_args = (args, dict(kwargs))     # the constructor arguments, for pickle, deepcopy and the twin
        return env

    def __reduce__(self):
        return reduce_env(self)

    def __init__(self, obs_mode: str = "state", image_size: int = 128, render_mode: str | None = None,
                 clip_actions: bool = False, record_trajectory: bool = False, with_panda: bool = True,
                 robot: str | None = None, physics_space: str | None = None, camera_noise: Any = None):
        self.hidden = self.hidden_model(self, physics_space)
        self.image_size = check_env_args(obs_mode, render_mode, image_size, clip_actions=clip_actions,
                                         record_trajectory=record_trajectory, with_panda=with_panda)
        self.camera_noise = cn.check_camera_noise(camera_noise)     # a CameraNoise, or None (off)
        executor = executor_for(robot, with_panda)
        self.robot = robot
        self.obs_mode = obs_mode
        self.render_mode = render_mode
        self.clip_actions = bool(clip_actions)
        self.record_trajectory = bool(record_trajectory)
        self.with_panda = bool(with_panda)
        self.executor = executor(self)
        self._build()

        self.action_space = action_space(self.action_dims)
        self._low64 = np.array([d.low for d in self.action_dims], dtype=np.float64)
        self._high64 = np.array([d.high for d in self.action_dims], dtype=np.float64)
        self.observation_space = observation_space(obs_mode, len(self.state_names), self.image_size)
        self.observer = Observer(self)
        self._context: dict[str, Any] | None = None
        self._needs_reset = True
        self._last_action: np.ndarray | None = None
        self._episode_record = False

    # ======================================================================================== to be declared by tasks
    def assemble(self) -> list:
        """The task's tools (:mod:`phyplan_envs.tools`), in the order they are built into the scene."""
        raise NotImplementedError(f"{type(self).__name__} must implement assemble")

    def sample_goal(self, rng: np.random.Generator) -> np.ndarray:
        """A goal (x, y) drawn with ``rng``."""
        raise NotImplementedError(f"{type(self).__name__} must implement sample_goal")

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
    def action_low(self) -> np.ndarray:
        """The lower action bounds, float64 (the action space's float32 bounds round them)."""
        return self._low64.copy()

    @property
    def action_high(self) -> np.ndarray:
        return self._high64.copy()

    @property
    def context(self) -> dict[str, Any]:
        """The current context (a copy), to pass back as ``reset(options={"context": ...})``."""
        if self._context is None:
            raise RuntimeError("call reset() before reading the context")
        return copy_context(self._context)

    @property
    def context_keys(self) -> tuple[str, ...]:
        """The entries of a context; a varied task's hidden physics adds its own."""
        return ("goal",) + self.hidden.context_keys + cn.context_keys(self.camera_noise)

    @property
    def reset_options(self) -> tuple[str, ...]:
        return ("context", "goal", "record_trajectory") + self.hidden.reset_options

    @property
    def hidden_physics(self) -> dict[str, float]:
        """A varied task's current hidden values (privileged; :mod:`phyplan_envs.hidden_physics`)."""
        return self.hidden.values()

    @property
    def hidden_parameters(self) -> tuple:
        """A varied task's hidden parameters (:class:`phyplan_envs.hidden_physics.HiddenParameter`), in order."""
        return self.hidden.parameters

    # ==================================================================================================== building
    def build_scene(self, root) -> None:
        """Add the tools' pieces and the cameras to ``root`` (the arena)."""
        self.tools.build(root)
        for name, pos, lookat, fovy in self.cameras:
            assets.add_camera(root, name, pos=pos, lookat=lookat, fovy=fovy)

    def _build(self) -> None:
        """Build the MJCF scene (arena, tools, hidden physics, the executor's arm), compile it and bind the parts."""
        root = assets.arena(self.task_name or "phyplan")
        root.option.timestep = self.timestep
        self.tools = Assembly(self.assemble(), self.action_dims, self.hand_tool)
        self.hidden.adapt(self.tools)
        self.build_scene(root)
        self.hidden.build(root)
        self.executor.attach(root)
        self.mjcf_model = root
        self.physics = compiled.compile_scene(root)     # a copy of the process's compiled scene (same bytes)
        self.scene = Scene(self.physics, self.object_name, self.task_name)
        self.model: mujoco.MjModel = self.scene.model
        self.data: mujoco.MjData = self.scene.data
        self.tools.bind(self.scene)
        self.executor.bind(self.physics)

    def kinematic_twin(self) -> "PhyPlanEnv":
        """This env in the kinematic mode without the Panda (robot mode's arm-free flight)."""
        return kinematic_twin(self, PhyPlanEnv.__init__)

    # ======================================================================================================= API
    def reset(self, *, seed: int | None = None, options: Mapping[str, Any] | None = None):
        self._check_open("reset")
        inputs = reset_inputs(self, seed, options)
        super().reset(seed=inputs.seed)
        context, what = episode_context(self, inputs)
        self.observer.noise = cn.realise(self.camera_noise, context, self.np_random)   # after the context's draws
        self._context = context
        self._episode_record = inputs.record

        self.start_state(context, self.hidden.override)
        self._start_pos = self.object_pos()
        self._d0 = float(np.linalg.norm(self._start_pos[:2] - context["goal"]))
        try:
            check_start_distance(self, context["goal"], self._start_pos, self._d0, what)
        except ValueError:
            self._context, self._needs_reset = None, True      # a failed reset leaves no usable episode
            raise
        self._needs_reset = False
        self._last_action = None
        self.observer.start_video(self.executor)
        info = {"goal": context["goal"].copy(), "object_pos": self._start_pos.copy(),
                "initial_distance": self._d0, "context": self.context}
        return self._observation(), info

    def step(self, action):
        action = self._take(action, "step")
        self.executor.execute(action, self.observer.frames)
        result = self._simulate()
        self.observer.end_video(self.executor, result["n_steps"])
        reward, info = outcome(result, self._context["goal"], self._d0)
        info.update(action=action.copy(), clipped=self._clipped, context=self.context)
        info.update(self.executor.info())
        if self._episode_record:
            info["trajectory"] = result["trajectory"]
        obs = self._observation(object_pos=result["final_pos"])
        return obs, reward, True, False, info

    def describe(self, actions) -> SceneDescription:
        """The scene's declarative description for ``actions`` ((A,) or (N, A), inside the bounds): the tools' poses
        after each action's set-up, the moving object and what sets it moving (:mod:`phyplan_envs.description`;
        a varied task names its hidden parameters instead of their values). Needs no reset."""
        a = np.asarray(actions, dtype=np.float64)
        a = a[None] if a.ndim == 1 else a
        if a.ndim != 2 or a.shape[1] != len(self.action_dims) or not np.all(np.isfinite(a)):
            raise ValueError(f"actions must be finite with shape (N, {len(self.action_dims)}), got shape {a.shape}")
        d = self.tools.describe(a, landing_height=self.landing_height, end_rule=self.end_rule)
        self.hidden.describe(d, a)
        return d

    def release(self, action) -> ObjectState:
        """Inspection: set up and release ``action`` as :meth:`step` would, without the flight; the object's state
        at the release. The episode is used up (``step`` needs a ``reset`` first); the physics may be stepped on."""
        self.executor.execute(self._take(action, "release"), self.observer.frames)
        return self.object_state()

    def _simulate(self) -> dict[str, Any]:
        """The flight from the released state until the end rule fires (the executor's)."""
        return timed(self.stage_timer, "flight", self.executor.simulate, self._episode_record)

    def _take(self, action, what: str) -> np.ndarray:
        """The checked float64 ``action`` of this episode's one attempt (``what`` names the call)."""
        self._check_open(what)
        if self._needs_reset:
            raise RuntimeError(f"{self.task_name}: one episode is one attempt; call reset() before {what}() again")
        action, self._clipped = check_action(action, self.action_dims, self._low64, self._high64,
                                             self.clip_actions, self.task_name)
        self._last_action = action
        self._needs_reset = True
        return action

    def render(self):
        self._check_open("render")
        if self.render_mode is None:
            return None
        if self._context is None:
            raise RuntimeError("call reset() before render()")
        if self.observer.frames is not None:
            return list(self.observer.frames.frames)     # this episode's frames so far (kept until the next reset)
        self.executor.pose_arm(self._last_action)
        mujoco.mj_forward(self.model, self.data)
        return self.observer.frame()

    def close(self):
        """Free the renderers and the compiled model now (with the Panda ~23 MB of MuJoCo buffers); afterwards
        ``reset``, ``step`` and ``render`` raise ``RuntimeError``. Closing again does nothing."""
        for name in ("observer", "executor", "scene"):
            part = getattr(self, name, None)
            if part is not None:
                part.close()
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
    def sample_context(self, rng: np.random.Generator) -> dict[str, Any]:
        """A new context drawn with ``rng``: ``{"goal": [x, y]}`` (a varied task's holds its hidden physics too)."""
        return self.hidden.sample_context(rng)

    def start_state(self, context: Mapping[str, Any], physics: Mapping[str, float] | None = None) -> None:
        """The simulator at the start of ``context`` (checked by ``reset``, or one of this env's own: robot mode's
        kinematic twin): data reset, goal placed, the scene's start (:meth:`reset_scene`), the executor's; a varied
        task's hidden values ``physics`` instead of the context's if given."""
        self.hidden.override = physics
        mujoco.mj_resetData(self.model, self.data)
        self.scene.place_goal(context["goal"])
        self.reset_scene(context)
        self.executor.reset(context, physics)
        mujoco.mj_forward(self.model, self.data)

    def reset_scene(self, context: Mapping[str, Any]) -> None:
        """The tools and the object at their start for ``context`` (after ``mj_resetData`` and the goal)."""
        self.hidden.reset_scene(context, self.tools.reset)

    def apply_action(self, action) -> None:
        """Set the tools for ``action`` (float64) and put the object at its release state (the kinematic set-up)."""
        action = np.asarray(action, dtype=np.float64)
        self.tools.apply(action)
        self.hidden.after_apply(action)

    def robot_plan(self, action) -> list:
        """Robot mode: set what the arm does not carry and return the arm's steps for ``action``
        (:class:`phyplan_envs.panda.robot.Carry`), the tools' in their order."""
        return self.tools.robot_steps(np.asarray(action, dtype=np.float64))

    # ================================================================================================== the hand
    def hand_target(self, action) -> np.ndarray:
        """The world point the Panda's hand holds at release for ``action`` (``None``: before any attempt): the
        hand tool's (:attr:`hand_tool`)."""
        return self.tools.hand_target(None if action is None else np.asarray(action, dtype=np.float64))

    def hand_axes(self, action):
        """The hand's world ``(approach, closing)`` for ``action`` if the hand tool chooses it, else ``None``."""
        return self.tools.hand_axes(None if action is None else np.asarray(action, dtype=np.float64))

    # ========================================================================================== scene and inspection
    def object_pos(self) -> np.ndarray:
        return self.scene.object_pos()

    def object_vel(self) -> np.ndarray:
        return self.scene.object_vel()

    def object_state(self) -> ObjectState:
        """The moving object's state now (copies)."""
        return self.scene.object_state()

    def body_id(self, name: str) -> int:
        return self.scene.body_id(name)

    def contact_pairs(self) -> list[tuple[str, str]]:
        """The geom names of every active contact (after ``mj_forward`` or a step)."""
        return self.scene.contact_pairs()

    def touching(self, geom1: str, geom2: str) -> bool:
        """Whether the geoms named ``geom1`` and ``geom2`` are in contact now."""
        return self.scene.touching(self.scene.geom_id(geom1), self.scene.geom_id(geom2))

    def camera_model(self, name: str = "obs") -> CameraModel:
        """The pinhole model (intrinsics, camera-to-world pose) of camera ``"obs"`` (at the observation's size)
        or ``"view"`` (at the ``render()`` frame's size); see :mod:`phyplan_envs.camera`. Nominal: with
        ``camera_noise`` the ``obs`` camera draws from a pose off by the context's error (:meth:`true_camera_model`)."""
        return self.observer.camera_model(name)

    def true_camera_model(self) -> CameraModel:
        """Inspection (privileged): the ``obs`` camera at the pose it draws this context's pictures from (with
        ``camera_noise``, the nominal pose moved by the context's error; else :meth:`camera_model`)."""
        return self.observer.true_camera_model()

    # =============================================================================================== observations
    def _observation(self, object_pos: np.ndarray | None = None):
        """The observation in ``obs_mode``; the state shows ``object_pos`` (default: the start position)."""
        p = self._start_pos if object_pos is None else object_pos
        return self.observer.observe(self._context["goal"], p, self.task_state)


# The attributes close() drops (each holds the model, the data or the MJCF tree).
_RELEASED_ON_CLOSE = ("physics", "model", "data", "mjcf_model", "scene", "tools", "pendulum", "hand_tool", "executor",
                      "observer")
