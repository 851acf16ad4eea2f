"""Skill data with perception (the paper's Fig. 5, left): the slide skill's samples read from camera frames.

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

The pipeline's errors (about a millimetre per position) become noise in ``x`` and, divided by the 20-60 ms
baselines, tens of mm/s in ``v`` and ``v_init``. The result is a :class:`~phyplan_envs.skill_scenes.SkillData` that
:func:`phyplan_agents.skills.training.fit` trains on as on the simulator's; ``extras`` keeps the simulator's values
of the same rows (``true_v_init``, ``true_x``, ``true_v``) for measuring the reading error only.
"""
from __future__ import annotations

import numpy as np

from phyplan_envs import skill_scenes
from phyplan_envs.skill_scenes import SkillData
from phyplan_envs.skill_scenes.frames import FRAME_STEPS, LAUNCH_FRAMES, slide_frames
from phyplan_envs.tasks.slide import FACTS as SLIDE_FACTS

from .scene import locate_object


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
