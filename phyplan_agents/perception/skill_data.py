"""Skill data with perception (the paper's Fig. 5, left): the slide and swing skills' samples read from camera frames.

:func:`slide_data` films every rollout of the slide skill's data (:func:`phyplan_envs.skill_scenes.frames.slide_frames`:
the same launches and query times as ``skill_scenes.generate("slide", n, seed)``, row for row) and reads each sample
from the frames with the perception pipeline (:func:`~phyplan_agents.perception.scene.locate_object`: the puck's
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

The pipeline's errors (about a millimetre per position) become noise in ``x`` and, divided by the 20-60 ms
baselines, tens of mm/s in ``v`` and ``v_init``. The result is a :class:`~phyplan_envs.skill_scenes.SkillData` that
:func:`phyplan_agents.skills.training.fit` trains on as on the simulator's; ``extras`` keeps the simulator's values
of the same rows (``true_v_init``, ``true_x``, ``true_v``) for measuring the reading error only.
"""
from __future__ import annotations

import numpy as np

from phyplan_envs import skill_scenes
from phyplan_envs.skill_scenes import SkillData
from phyplan_envs.skill_scenes.frames import FRAME_STEPS, LAUNCH_FRAMES, slide_frames, swing_frames
from phyplan_envs.tasks.slide import FACTS as SLIDE_FACTS

from . import vision as V
from .scene import PerceptionError, RGBDView, locate_object


def read_slide_sample(sample: dict) -> tuple[float, float, float, float]:
    """``(v_init, t, x, v)`` read from one sample's frames (module docstring)."""
    cam, frames, times, k = sample["camera"], sample["frames"], sample["times"], sample["k"]
    pos = {j: locate_object(f, cam, "puck", SLIDE_FACTS.puck_radius, SLIDE_FACTS.puck_half_height)[:2]
           for j, f in frames.items()}
    launch = [j * FRAME_STEPS for j in range(LAUNCH_FRAMES)]
    p0 = pos[0]
    direction = pos[launch[-1]] - p0
    direction = direction / np.linalg.norm(direction)

    def dist(j: int) -> float:
        return float((pos[j] - p0) @ direction)

    t = np.array([times[j] for j in launch[1:]])
    a = np.column_stack([t, -0.5 * t * t])
    (v_init, _), *_ = np.linalg.lstsq(a, np.array([dist(j) for j in launch[1:]]), rcond=None)
    steps = sorted(frames)
    before = max(j for j in steps if j <= max(k - FRAME_STEPS, 0))
    after = max(steps)
    if after <= k:           # the query frame is the last one: a backward difference
        before, after = max(j for j in steps if j < k), k
    v = (dist(after) - dist(before)) / (times[after] - times[before])
    return float(v_init), float(times[k]), dist(k), float(v)


def slide_data(n: int, seed: int, progress: bool = False) -> SkillData:
    """``n`` slide samples read from camera frames (module docstring); row ``i`` is the launch and query time of
    row ``i`` of ``skill_scenes.generate("slide", n, seed)``."""
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    x, y = np.empty((n, 2)), np.empty((n, 2))
    truth = {"true_v_init": np.empty(n), "true_x": np.empty(n), "true_v": np.empty(n)}
    samples = slide_frames(n, seed, skill_scenes._SKILL_SALT["slide"])
    if progress:
        from tqdm.auto import tqdm
        samples = tqdm(samples, total=n, desc="slide frames", unit="sample", leave=False)
    for i, sample in enumerate(samples):
        v_init, t, dist, v = read_slide_sample(sample)
        x[i], y[i] = (v_init, t), (dist, v)
        truth["true_v_init"][i] = sample["truth"]["v_init"]
        truth["true_x"][i] = sample["truth"]["x"]
        truth["true_v"][i] = sample["truth"]["v"]
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
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    samples = swing_frames(n, seed, skill_scenes._SKILL_SALT["swing"])
    if progress:
        from tqdm.auto import tqdm
        samples = tqdm(samples, total=n, desc="swing frames", unit="sample", leave=False)
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
        steps = sorted(centres)
        before, after = max(j for j in steps if j <= max(k - FRAME_STEPS, 0)), max(steps)
        omega = (angle(centres[after]) - angle(centres[before])) / (times[after] - times[before])
        x[i] = (angle(centres[0]), times[k])
        y[i] = (angle(centres[k]), omega)
    return SkillData("swing", x, y, int(seed), truth)
