"""Env speed: episodes per second per task and observation mode, against MuJoCo's raw step rate.

    python -m benchmarks.env_speed [--tasks launch slide ...] [--episodes 40] [--repeats 5]

For each task it plays the same ``--episodes`` random attempts (fixed seeds) through ``env.reset`` + ``env.step``
and times them; the *raw physics bound* replays exactly the same physics steps (same model, same initial state,
same number of steps per episode) as one ``mujoco.mj_step(model, data, nstep=n)`` call per episode, with no Python
in the loop. ``ratio = raw time / env time`` (1.0 = no overhead; the target is >= 0.5 for state observations).
Image modes print the extra milliseconds per episode over the state mode (target <= 20 ms at 128 x 128).
All figures are medians over ``--repeats`` repeats. Run it with the Panda on (the default of the tasks) or off.
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


def _actions(env, n, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    return lo + (hi - lo) * rng.random((n, len(lo)))


def time_env(task: str, mode: str, episodes: int, repeats: int, with_panda: bool):
    env = gym.make(phyplan_envs.env_id(task), obs_mode=mode, with_panda=with_panda)
    acts = _actions(env, episodes)
    env.reset(seed=0)  # warm-up: lazy renderer creation is not part of the per-episode cost
    env.step(acts[0])
    times, steps = [], None
    for _ in range(repeats):
        n_steps = []
        t0 = time.perf_counter()
        for i, a in enumerate(acts):
            env.reset(seed=i)
            _, _, _, _, info = env.step(a)
            n_steps.append(info["n_steps"])
        times.append(time.perf_counter() - t0)
        steps = n_steps
    env.close()
    return statistics.median(times), steps


def time_raw(task: str, episodes: int, repeats: int, steps, with_panda: bool):
    """The same physics steps, from the same initial states, as one mj_step(nstep) call per episode."""
    env = gym.make(phyplan_envs.env_id(task), with_panda=with_panda).unwrapped
    acts = _actions(env, episodes)
    m, d = env.model, env.data
    starts = []
    for i, a in enumerate(acts):
        env.reset(seed=i)
        env.apply_action(a)
        mujoco.mj_forward(m, d)
        starts.append((m.body_pos.copy(), m.body_quat.copy(), d.qpos.copy(), d.qvel.copy()))
    times = []
    for _ in range(repeats):
        t = 0.0
        for (bp, bq, qp, qv), n in zip(starts, steps):
            m.body_pos[:] = bp
            m.body_quat[:] = bq
            mujoco.mj_resetData(m, d)
            d.qpos[:] = qp
            d.qvel[:] = qv
            t0 = time.perf_counter()
            mujoco.mj_step(m, d, nstep=n)
            t += time.perf_counter() - t0
        times.append(t)
    env.close()
    return statistics.median(times), int(sum(steps))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tasks", nargs="+", default=list(phyplan_envs.TASKS), choices=list(phyplan_envs.TASKS))
    p.add_argument("--modes", nargs="+", default=["state", "image", "state_image"])
    p.add_argument("--episodes", type=int, default=40)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--no-panda", action="store_true", help="build the scenes without the Panda")
    args = p.parse_args(argv)
    with_panda = not args.no_panda
    print(f"mujoco {mujoco.__version__}, MUJOCO_GL={os.environ.get('MUJOCO_GL')}, panda={'on' if with_panda else 'off'}, "
          f"{args.episodes} episodes x {args.repeats} repeats (medians)")
    header = (f"{'task':8s} {'obs':12s} {'ep/s':>8s} {'ms/ep':>7s} {'raw ep/s':>9s} {'raw steps/s':>12s} "
              f"{'ratio':>6s} {'+ms vs state':>13s}")
    print(header)
    print("-" * len(header))
    for task in args.tasks:
        base_ms = None
        raw_t, raw_steps = None, None
        for mode in args.modes:
            t, steps = time_env(task, mode, args.episodes, args.repeats, with_panda)
            if raw_t is None:
                raw_t, raw_steps = time_raw(task, args.episodes, args.repeats, steps, with_panda)
            ms = 1e3 * t / args.episodes
            if mode == "state":
                base_ms = ms
            extra = "" if base_ms is None or mode == "state" else f"{ms - base_ms:+.2f}"
            print(f"{task:8s} {mode:12s} {args.episodes / t:8.1f} {ms:7.2f} {args.episodes / raw_t:9.1f} "
                  f"{raw_steps / raw_t:12.0f} {raw_t / t:6.2f} {extra:>13s}")


if __name__ == "__main__":
    main()
