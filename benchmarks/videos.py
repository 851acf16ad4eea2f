"""Videos of a benchmark run: one MP4 per (task, agent, run seed, context), its attempts one after another.

``python -m benchmarks.run ... --video DIR`` calls :func:`write_videos` after the run: for the first
``--video-contexts`` contexts of each task (in context-id order) and every agent and run seed, the recorded actions
are replayed on an env made with ``render_mode="rgb_array_list"`` (``robot="panda"`` with ``--video-robot``), and
the frames of every attempt (:mod:`phyplan_envs.video`: the set-up, the release, the flight) are written at the
env's ``metadata["render_fps"]`` with imageio's ffmpeg writer (the ``imageio-ffmpeg`` package, which carries its own
ffmpeg binary). The envs are deterministic, so the kinematic-mode replay reproduces the recorded attempts exactly
(the rewards are checked); robot mode shows the arm executing the same actions, whose outcomes differ slightly
(docs/robot.md).
"""
from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

REWARD_TOL = 1e-9     # a kinematic replay must give the recorded reward (the env is deterministic)


def video_name(task: str, agent: str, seed: int, context: int) -> str:
    return f"{task}_{agent}_seed{seed}_ctx{context}.mp4"


def select_cells(records: Iterable, contexts: int) -> dict[tuple, list]:
    """``(task, agent, seed, context) -> attempts in order`` for the first ``contexts`` contexts of each task."""
    by_cell: dict[tuple, list] = defaultdict(list)
    task_contexts: dict[str, set] = defaultdict(set)
    for r in records:
        by_cell[(r.task, r.agent, r.seed, r.context)].append(r)
        task_contexts[r.task].add(r.context)
    keep = {t: set(sorted(c)[:contexts]) for t, c in task_contexts.items()}
    return {k: sorted(v, key=lambda r: r.attempt) for k, v in sorted(by_cell.items()) if k[3] in keep[k[0]]}


def write_mp4(path: Path, frames: Sequence[np.ndarray], fps: float) -> None:
    """Write ``frames`` (uint8 H x W x 3) as an H.264 MP4 at ``fps``."""
    import imageio.v2 as imageio

    with imageio.get_writer(str(path), fps=fps, codec="libx264", quality=7, macro_block_size=1,
                            ffmpeg_log_level="error") as w:
        for f in frames:
            w.append_data(f)


def write_videos(records: Iterable, out_dir, contexts: int = 2, robot: str | None = None,
                 log=None) -> list[Path]:
    """Replay the attempts of the selected cells (see the module docstring) and write one MP4 per cell.

    Returns the paths written. Raises ``ValueError`` for ``contexts < 1`` and ``RuntimeError`` if a kinematic
    replay does not reproduce a recorded reward.
    """
    import gymnasium as gym

    import phyplan_envs

    if not (isinstance(contexts, int) and contexts >= 1):
        raise ValueError(f"contexts (--video-contexts) must be an integer >= 1, got {contexts!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cells = select_cells(records, contexts)
    envs: dict[str, object] = {}
    written = []
    try:
        for (task, agent, seed, context), attempts in cells.items():
            if task not in envs:
                envs[task] = gym.make(phyplan_envs.env_id(task), render_mode="rgb_array_list", robot=robot)
            env = envs[task]
            frames: list[np.ndarray] = []
            for rec in attempts:
                if rec.action is None:       # an attempt that failed before stepping has nothing to show
                    continue
                env.reset(seed=context)
                _, reward, _, _, _ = env.step(np.asarray(rec.action, dtype=np.float64))
                if robot is None and rec.reward is not None and not math.isclose(reward, rec.reward,
                                                                                 rel_tol=0, abs_tol=REWARD_TOL):
                    raise RuntimeError(f"replay of {task}/{agent} seed {seed} context {context} attempt "
                                       f"{rec.attempt} gave reward {reward!r}, the record says {rec.reward!r}")
                frames.extend(env.render())
            if not frames:
                continue
            path = out / video_name(task, agent, seed, context)
            write_mp4(path, frames, env.metadata["render_fps"])
            written.append(path)
            if log is not None:
                log(f"video: {path} ({len(frames)} frames)")
    finally:
        for env in envs.values():
            env.close()
    return written
