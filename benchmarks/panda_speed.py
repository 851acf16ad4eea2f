"""What the visual-only Panda costs: stepping and episode rates of every task with and without it, and render() time.

    python -m benchmarks.panda_speed [--tasks launch ...] [--steps 4000] [--repeats 7] [--episodes 20] [--frames 10]

Per task, two envs are made (``with_panda=False`` and ``True``) and timed back to back in every repeat, so that
load changes on a shared machine hit both alike:

* ``steps/s``: ``mj_step(nstep=steps)`` from the released state of one fixed attempt (no Python in the loop);
* ``episodes/s``: ``reset(seed=i)`` + ``step(a_i)`` over ``episodes`` fixed random attempts (state observations);
* ``ms/frame``: one 480 x 480 ``render()`` frame after an attempt (the arm's IK pose is cached after the first).

Stepping and episode times are CPU time of this process (``time.process_time``), so other processes disturb them
less; render times are wall-clock (``time.perf_counter``), as the GL driver may work outside this process. The
with/without ratios are medians of the paired repeats, steadier than ratios of medians on a loaded machine.
The figures quoted in ``docs/panda.md`` come from this command.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium as gym  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

import phyplan_envs  # noqa: E402


def _actions(env, n: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    return lo + (hi - lo) * rng.random((n, len(lo)))


def _positive(name: str, value: int) -> int:
    if not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def benchmark_stepping(tasks=None, steps: int = 4000, repeats: int = 7, episodes: int = 20,
                       frames: int = 10) -> list[dict]:
    """One row per (task, with_panda): model sizes, median steps/s, episodes/s, ms per render() frame, and the
    paired with/without ratios of the task (the same in both of its rows)."""
    steps, repeats = _positive("steps", steps), _positive("repeats", repeats)
    episodes, frames = _positive("episodes", episodes), _positive("frames", frames)
    rows = []
    for task in (tasks or list(phyplan_envs.TASKS)):
        envs, acts = {}, None
        for with_panda in (False, True):
            env = gym.make(phyplan_envs.env_id(task), with_panda=with_panda, render_mode="rgb_array").unwrapped
            if acts is None:
                acts = _actions(env, episodes)
            envs[with_panda] = env
        rates: dict[bool, list[float]] = {False: [], True: []}
        eps: dict[bool, list[float]] = {False: [], True: []}
        render_ms: dict[bool, list[float]] = {False: [], True: []}
        for _ in range(repeats):
            for with_panda, env in envs.items():
                m, d = env.model, env.data
                env.reset(seed=0)
                env.apply_action(acts[0])
                mujoco.mj_forward(m, d)
                t0 = time.process_time()
                mujoco.mj_step(m, d, nstep=steps)
                rates[with_panda].append(steps / (time.process_time() - t0))
                t0 = time.process_time()
                for i, a in enumerate(acts):
                    env.reset(seed=i)
                    env.step(a)
                eps[with_panda].append(episodes / (time.process_time() - t0))
                env.render()                  # the first frame makes the renderer and solves the IK: not timed
                t0 = time.perf_counter()
                for _ in range(frames):
                    env.render()
                render_ms[with_panda].append(1e3 * (time.perf_counter() - t0) / frames)
        ratios = {"paired_step_ratio": statistics.median(b / a for a, b in zip(rates[False], rates[True])),
                  "paired_episode_ratio": statistics.median(b / a for a, b in zip(eps[False], eps[True])),
                  "paired_render_ratio": statistics.median(b / a for a, b in zip(render_ms[False], render_ms[True]))}
        for with_panda, env in envs.items():
            m = env.model
            rows.append({"task": task, "with_panda": with_panda, "nq": m.nq, "nbody": m.nbody, "ngeom": m.ngeom,
                         "steps_per_s": statistics.median(rates[with_panda]),
                         "episodes_per_s": statistics.median(eps[with_panda]),
                         "render_ms": statistics.median(render_ms[with_panda]), **ratios})
            env.close()
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=list(phyplan_envs.TASKS), choices=list(phyplan_envs.TASKS))
    parser.add_argument("--steps", type=int, default=4000, help="physics steps per raw-rate repeat")
    parser.add_argument("--repeats", type=int, default=7, help="repeats; medians are printed")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per env-rate repeat")
    parser.add_argument("--frames", type=int, default=10, help="render() frames per render-time repeat")
    args = parser.parse_args(argv)
    rows = benchmark_stepping(args.tasks, args.steps, args.repeats, args.episodes, args.frames)
    print(f"mujoco {mujoco.__version__}, MUJOCO_GL={os.environ.get('MUJOCO_GL')}, {args.repeats} paired repeats")
    print(f"{'task':8s} {'panda':5s} {'nq':>3s} {'nbody':>5s} {'ngeom':>5s} {'steps/s':>9s} {'episodes/s':>10s} "
          f"{'ms/frame':>8s}")
    for r in rows:
        print(f"{r['task']:8s} {str(r['with_panda']):5s} {r['nq']:3d} {r['nbody']:5d} {r['ngeom']:5d} "
              f"{r['steps_per_s']:9.0f} {r['episodes_per_s']:10.1f} {r['render_ms']:8.2f}")
    for r in rows:
        if r["with_panda"]:
            print(f"{r['task']}: with/without Panda (median of paired repeats) = {r['paired_step_ratio']:.2f}x "
                  f"steps/s, {r['paired_episode_ratio']:.2f}x episodes/s, {r['paired_render_ratio']:.2f}x ms/frame")


if __name__ == "__main__":
    main()
