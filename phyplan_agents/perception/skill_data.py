"""Skill data with perception (the paper's Fig. 5, left): the slide, swing and throw skills' samples read from camera
frames.

:func:`slide_data` films every rollout of the slide skill's data (:func:`phyplan_envs.skill_scenes.frames.slide_frames`:
the same launches and query times as ``skill_scenes.generate("slide", n, seed)``, row for row) and reads each sample
from the frames with the perception pipeline (:func:`~phyplan_agents.perception.reads.locate_object`: the puck's
top-face outline, a circle fit). Nothing else is taken from the simulator:

* ``v_init``: a least-squares fit of ``x = v0 t - a t^2 / 2`` to the puck's distance from its first position in the
  first four frames (0-60 ms after the launch);
* ``t``: the query frame's time stamp (exact, as a camera's clock would be);
* ``x``: the distance from the first frame's position to the query frame's, along the direction of motion (the
  line from the first to the fourth frame's position);
* ``v``: the central difference of the distance over the frames one period before and after the query frame
  (one-sided in the first period).

:func:`swing_data` does the same for the swing skill (:func:`~phyplan_envs.skill_scenes.frames.swing_frames`): the
bob's centre in each frame is the centroid of its front face (the blue pixels on the plane nearest the camera, which
looks along the hinge axis); the pivot is a circle fit to the bob's centres over every frame of the data set (a
calibration of the rig from the pictures); ``theta`` is the bob's angle about it (``theta_init`` from the release
frame), ``omega`` its central difference over the frames one period before and after.

:func:`throw_data` does the same for the throw skill (:func:`~phyplan_envs.skill_scenes.frames.throw_frames`): the
ball is a sphere of the known radius fitted to its surface points (``locate_object(..., "ball", ...)``) in each
frame, seen in the flight plane (x along the world's +x, heights z). ``v_hor`` and ``v_ver`` are fits of
``d = v t - a t^2 / 2`` (v and a free, as for the slide) to the ball's horizontal and vertical distance from its
first position over the first four frames; ``x`` and ``y`` are the horizontal and vertical displacement from the
first frame's position to the query frame's, ``v_ver`` at the query time the central difference of the height.

The pipeline's errors (about a millimetre per position for the puck and the bob; ~0.03 mm for the ball, whose
surface points pin its centre) become noise in the positions and, divided by the 20-60 ms baselines, tens of mm/s
in the slide's and swing's velocities (the throw's: a few mm/s, mostly the differences' half-step lag on MuJoCo's
semi-implicit Euler, ``g dt / 2``). The result is a :class:`~phyplan_envs.skill_scenes.SkillData` that
:func:`phyplan_agents.skills.training.fit` trains on as on the simulator's; ``extras`` keeps the simulator's values
of the same rows (``true_v_init``, ``true_x``, ``true_v``; swing ``true_theta_init``, ``true_theta``,
``true_omega``; throw ``true_v_hor``, ``true_v_ver``, ``true_x``, ``true_y``, ``true_v_ver_t``) for measuring the
reading error only.
"""
from __future__ import annotations

import numpy as np

from phyplan_envs import assets, skill_scenes
from phyplan_envs.skill_scenes import SkillData
from phyplan_envs.skill_scenes.frames import FRAME_STEPS, LAUNCH_FRAMES, slide_frames, swing_frames, throw_frames
from phyplan_envs.tasks.slide import FACTS as SLIDE_FACTS

from . import vision as V
from .reads import PerceptionError, RGBDView, locate_object


LAUNCH = tuple(j * FRAME_STEPS for j in range(LAUNCH_FRAMES))     # the launch frames' steps (0, 20, 40, 60)


def _span(sample: dict) -> tuple[int, int]:
    """The steps of the frames one frame period before and after the query step ``k`` (before: at least the first
    frame, so one-sided in the first period); a ValueError if the sample lacks one of them or a launch frame."""
    k, frames = sample["k"], sample["frames"]
    before, after = max(k - FRAME_STEPS, 0), k + FRAME_STEPS
    missing = sorted({*LAUNCH, before, k, after} - set(frames))
    if missing:
        raise ValueError(f"the sample has no frames at steps {missing} (needs the launch frames {list(LAUNCH)} and "
                         f"k - {FRAME_STEPS}, k, k + {FRAME_STEPS} for k = {k})")
    return before, after


def launch_velocity(times, dist) -> float:
    """The initial velocity ``v`` of a least-squares fit of ``dist = v t - a t^2 / 2`` (v and a free) to distances
    from the first frame's position at ``times`` after it (at least two)."""
    t = np.asarray(times, dtype=np.float64)
    if t.ndim != 1 or len(t) < 2 or len(dist) != len(t):
        raise ValueError(f"a launch fit needs >= 2 times and as many distances, got {len(t)} and {len(dist)}")
    a = np.column_stack([t, -0.5 * t * t])
    (v, _), *_ = np.linalg.lstsq(a, np.asarray(dist, dtype=np.float64), rcond=None)
    return float(v)


def _samples(frames_fn, skill: str, n: int, seed: int, progress: bool):
    """The skill's filmed samples (``n`` checked), with a progress bar if asked."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    samples = frames_fn(n, seed, skill_scenes._SKILL_SALT[skill])
    if progress:
        from tqdm.auto import tqdm
        samples = tqdm(samples, total=n, desc=f"{skill} frames", unit="sample", leave=False)
    return samples


def read_slide_sample(sample: dict) -> tuple[float, float, float, float]:
    """``(v_init, t, x, v)`` read from one sample's frames (module docstring)."""
    cam, frames, times, k = sample["camera"], sample["frames"], sample["times"], sample["k"]
    before, after = _span(sample)
    pos = {j: locate_object(f, cam, "puck", SLIDE_FACTS.puck_radius, SLIDE_FACTS.puck_half_height)[:2]
           for j, f in frames.items()}
    p0 = pos[0]
    direction = pos[LAUNCH[-1]] - p0
    direction = direction / np.linalg.norm(direction)

    def dist(j: int) -> float:
        return float((pos[j] - p0) @ direction)

    v_init = launch_velocity([times[j] for j in LAUNCH[1:]], [dist(j) for j in LAUNCH[1:]])
    v = (dist(after) - dist(before)) / (times[after] - times[before])
    return v_init, float(times[k]), dist(k), float(v)


def slide_data(n: int, seed: int, progress: bool = False) -> SkillData:
    """``n`` slide samples read from camera frames (module docstring); row ``i`` is the launch and query time of
    row ``i`` of ``skill_scenes.generate("slide", n, seed)``."""
    samples = _samples(slide_frames, "slide", n, seed, progress)
    x, y = np.empty((n, 2)), np.empty((n, 2))
    truth = {"true_v_init": np.empty(n), "true_x": np.empty(n), "true_v": np.empty(n)}
    for i, sample in enumerate(samples):
        v_init, t, dist, v = read_slide_sample(sample)
        x[i], y[i] = (v_init, t), (dist, v)
        for key in ("v_init", "x", "v"):
            truth[f"true_{key}"][i] = sample["truth"][key]
    return SkillData("slide", x, y, int(seed), truth)


def bob_centre(frame: dict, cam) -> np.ndarray:
    """The pendulum bob's centre (x, z) in one frame of :func:`~phyplan_envs.skill_scenes.frames.swing_frames`:
    the centroid of the blue blob's pixels on its front face (within 3 mm of the nearest blue point's y)."""
    view = RGBDView(frame, cam)
    b = view.blob("blue", "bob")
    if b is None:
        raise PerceptionError("bob: " + "; ".join(view.problems))
    pts = V.world_points(view.cam, view.depth, b.mask)
    front = pts[pts[:, 1] < pts[:, 1].min() + 0.003]
    return front[:, [0, 2]].mean(axis=0)


def swing_data(n: int, seed: int, progress: bool = False) -> SkillData:
    """``n`` swing samples read from camera frames (module docstring); row ``i`` is the release angle and query
    time of row ``i`` of ``skill_scenes.generate("swing", n, seed)``."""
    samples = _samples(swing_frames, "swing", n, seed, progress)
    seen, truth = [], {"true_theta_init": np.empty(n), "true_theta": np.empty(n), "true_omega": np.empty(n)}
    for i, sample in enumerate(samples):
        seen.append((sample["k"], sample["times"], {j: bob_centre(f, sample["camera"])
                                                    for j, f in sample["frames"].items()}))
        for key in ("theta_init", "theta", "omega"):
            truth[f"true_{key}"][i] = sample["truth"][key]
    pivot, _ = V.fit_circle(np.concatenate([list(c.values()) for _, _, c in seen]))

    def angle(c: np.ndarray) -> float:
        return float(np.arctan2(-(c[0] - pivot[0]), -(c[1] - pivot[1])))

    x, y = np.empty((n, 2)), np.empty((n, 2))
    for i, (k, times, centres) in enumerate(seen):
        before, after = max(k - FRAME_STEPS, 0), k + FRAME_STEPS
        omega = (angle(centres[after]) - angle(centres[before])) / (times[after] - times[before])
        x[i] = (angle(centres[0]), times[k])
        y[i] = (angle(centres[k]), omega)
    return SkillData("swing", x, y, int(seed), truth)


def ball_centre(frame: dict, cam) -> np.ndarray:
    """The ball's centre (x, z) in the flight plane in one frame of
    :func:`~phyplan_envs.skill_scenes.frames.throw_frames`: a sphere of the known radius fitted to its surface."""
    return locate_object(frame, cam, "ball", assets.BALL_RADIUS)[[0, 2]]


def read_throw_sample(sample: dict) -> tuple[float, float, float, float, float, float]:
    """``(v_hor, v_ver, t, x, y, v_ver at t)`` read from one sample's frames (module docstring)."""
    cam, frames, times, k = sample["camera"], sample["frames"], sample["times"], sample["k"]
    before, after = _span(sample)
    pos = {j: ball_centre(f, cam) for j, f in frames.items()}
    p0 = pos[0]
    v_hor, v_ver = (launch_velocity([times[j] for j in LAUNCH[1:]], [pos[j][c] - p0[c] for j in LAUNCH[1:]])
                    for c in (0, 1))
    v_ver_t = (pos[after][1] - pos[before][1]) / (times[after] - times[before])
    x, y = pos[k] - p0
    return v_hor, v_ver, float(times[k]), float(x), float(y), float(v_ver_t)


def throw_data(n: int, seed: int, progress: bool = False) -> SkillData:
    """``n`` throw samples read from camera frames (module docstring); row ``i`` is the launch and query time of
    row ``i`` of ``skill_scenes.generate("throw", n, seed)``."""
    samples = _samples(throw_frames, "throw", n, seed, progress)
    x, y = np.empty((n, 3)), np.empty((n, 3))
    keys = ("v_hor", "v_ver", "x", "y", "v_ver_t")
    truth = {f"true_{key}": np.empty(n) for key in keys}
    for i, sample in enumerate(samples):
        v_hor, v_ver, t, dx, dy, v_ver_t = read_throw_sample(sample)
        x[i], y[i] = (v_hor, v_ver, t), (dx, dy, v_ver_t)
        for key in keys:
            truth[f"true_{key}"][i] = sample["truth"][key]
    return SkillData("throw", x, y, int(seed), truth)
