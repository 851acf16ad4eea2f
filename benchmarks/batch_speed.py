"""Speed of batched simulation: throughput by worker count, and cost per episode against MuJoCo's raw step bound.

Usage::

    python -m benchmarks.batch_speed --actions 512 --workers 1 2 --repeats 3

For every task: one context (``env.reset(seed=--seed)``) and ``--actions`` uniform random actions, simulated with
:func:`phyplan_envs.batch.simulate_batch` at each worker count (the pool is started and warmed before timing).
Each timing is the best of ``--repeats`` (the machine is shared; the best is the least disturbed), the repeats
interleave the worker counts and the raw bound, and the load average is printed before and after.

Columns: episodes per second at each worker count, the speed-up of the largest count over 1 worker (target
>= 1.8x on 2 cores; below the table, the *control*: the speed-up that independent single-env processes got from
the machine at that time, which bounds it on a shared machine), and ``raw / batch``: MuJoCo's raw step bound (the same episodes' physics steps as one
``mj_step(model, data, nstep=n_steps)`` call each from the released state, no Python in the loop and no
reset) divided by the batch path's seconds per episode per core (target >= 0.8). The rows are also written to
``--out`` as CSV if given.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import time

import numpy as np


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover
        return "n/a"


def _worker_rss(workers: int) -> str:
    """Resident memory of the workers of the pool of ``workers`` processes (Linux ``/proc``), e.g. ``"512 MB"``."""
    from phyplan_envs.batch import worker_pool

    if workers < 2:
        return "n/a (1 worker runs in this process)"
    out = []
    for w in worker_pool(workers).workers:
        try:
            with open(f"/proc/{w.proc.pid}/status") as f:
                kb = next(int(line.split()[1]) for line in f if line.startswith("VmRSS"))
            out.append(f"{kb / 1024:.0f} MB")
        except (OSError, StopIteration):
            out.append("n/a")
    return ", ".join(out)


_CONTROL = """
import sys, time
import gymnasium as gym, numpy as np
import phyplan_envs
env = gym.make("PhyPlan/Launch-v0")
ctx = env.reset(seed=0)[1]["context"]
a = np.array([0.5, 1.0])
env.reset(options={"context": ctx}); env.step(a)
t0, n = time.perf_counter(), 0
while time.perf_counter() - t0 < float(sys.argv[1]):
    env.reset(options={"context": ctx}); env.step(a); n += 1
print(n / (time.perf_counter() - t0))
"""


def control_speedup(workers: int, seconds: float = 4.0) -> float:
    """What the machine gives right now: episodes/s of ``workers`` independent single-env processes run at once,
    over that of one (a loaded shared machine gives less than ``workers``)."""
    import subprocess

    def run(k: int) -> float:
        procs = [subprocess.Popen([sys.executable, "-c", _CONTROL, str(seconds)], stdout=subprocess.PIPE, text=True)
                 for _ in range(k)]
        return sum(float(p.communicate()[0]) for p in procs)

    return run(workers) / run(1)


def raw_step_seconds(env, context, actions: np.ndarray, n_steps: np.ndarray) -> float:
    """Seconds of ``mj_step(nstep=n)`` from each episode's released state (the physics alone)."""
    import mujoco

    u = env.unwrapped
    total = 0.0
    for a, n in zip(actions, n_steps):
        u.reset(options={"context": context})
        u.apply_action(np.clip(a, u.action_low, u.action_high))   # the release, as in env.step (actions in bounds)
        mujoco.mj_forward(u.model, u.data)
        t0 = time.perf_counter()
        mujoco.mj_step(u.model, u.data, nstep=int(n))
        total += time.perf_counter() - t0
    return total


def rollout_candidate(task: str, n_eps: int, steps: int, threads: int, seed: int) -> dict:
    """The rejected design, measured: ``mujoco.rollout`` over per-episode ``MjModel`` copies.

    Returns the cost of copying the model per episode (each episode's tools are placed in the model), rollout's
    seconds per physics step over ``n_eps`` episodes x ``steps`` steps on ``threads`` threads, and whether
    rollouts split into two calls (the state of the first call's last step as the second's start; rollout returns
    no ``qacc_warmstart``) and in one call reproduce the env's own stepping bit for bit.
    """
    import copy

    import gymnasium as gym
    import mujoco
    from mujoco import rollout

    import phyplan_envs

    u = gym.make(phyplan_envs.env_id(task)).unwrapped
    ctx = u.reset(seed=seed)[1]["context"]
    lo, hi = u.action_low, u.action_high
    acts = lo + (hi - lo) * np.random.default_rng([seed, 16]).random((n_eps, len(lo)))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    models, states, warm, t_copy = [], [], [], 0.0
    for a in acts:
        u.reset(options={"context": ctx})
        u.apply_action(a)
        mujoco.mj_forward(u.model, u.data)
        t0 = time.perf_counter()
        models.append(copy.copy(u.model))
        t_copy += time.perf_counter() - t0
        st = np.empty(mujoco.mj_stateSize(u.model, spec))
        mujoco.mj_getState(u.model, u.data, st, spec)
        states.append(st)
        warm.append(u.data.qacc_warmstart.copy())
    datas = [mujoco.MjData(models[0]) for _ in range(max(1, threads))]
    states, warm = np.array(states), np.array(warm)
    t0 = time.perf_counter()
    whole = rollout.rollout(models, datas, states, nstep=steps, initial_warmstart=warm)[0]
    t_roll = time.perf_counter() - t0
    half = rollout.rollout(models, datas, states, nstep=steps // 2, initial_warmstart=warm)[0]
    rest = rollout.rollout(models, datas, half[:, -1], nstep=steps - steps // 2)[0]
    nq = u.model.nq
    one_call = split = True
    for k, a in enumerate(acts):                       # the env's own stepping: mj_step in chunks of 5
        u.reset(options={"context": ctx})
        u.apply_action(a)
        mujoco.mj_forward(u.model, u.data)
        for _ in range(steps // u.chunk):
            mujoco.mj_step(u.model, u.data, u.chunk)
        one_call &= bool(np.array_equal(whole[k, -1, 1:1 + nq], u.data.qpos))
        split &= bool(np.array_equal(rest[k, -1, 1:1 + nq], u.data.qpos))
    return {"task": task, "model_copy_ms": 1e3 * t_copy / n_eps, "rollout_us_per_step": 1e6 * t_roll / (n_eps * steps),
            "one_call_identical": one_call, "split_identical": split}


def measure(task: str, n_actions: int, workers: list[int], repeats: int, seed: int) -> dict:
    import gymnasium as gym

    import phyplan_envs
    from phyplan_envs.batch import simulate_batch

    env_id = phyplan_envs.env_id(task)
    env = gym.make(env_id)
    context = env.reset(seed=seed)[1]["context"]
    u = env.unwrapped
    lo, hi = u.action_low, u.action_high
    actions = lo + (hi - lo) * np.random.default_rng([seed, 15]).random((n_actions, len(lo)))
    row: dict = {"task": task, "actions": n_actions}
    for w in workers:
        t0 = time.perf_counter()
        simulate_batch(env_id, context, actions[: 4 * w], workers=w)      # start and warm the pool / env
        row[f"warmup_s_w{w}"] = time.perf_counter() - t0
    ref = simulate_batch(env_id, context, actions, workers=workers[0])
    n_steps = np.array([i["n_steps"] for i in ref.info])
    # the repeats interleave every worker count and the raw bound, so that a change of the machine's load during
    # the run affects them alike; the best of the repeats is kept for each
    best = {w: np.inf for w in workers}
    raw = np.inf
    for _ in range(repeats):
        for w in workers:
            t0 = time.perf_counter()
            res = simulate_batch(env_id, context, actions, workers=w)
            best[w] = min(best[w], time.perf_counter() - t0)
            if not (np.array_equal(ref.reward, res.reward) and np.array_equal(ref.final_pos, res.final_pos)):
                raise RuntimeError(f"{task}: workers={w} gave other outcomes than workers={workers[0]}")
        raw = min(raw, raw_step_seconds(env, context, actions, n_steps))
    for w in workers:
        row[f"s_w{w}"] = best[w]
        row[f"eps_per_s_w{w}"] = n_actions / best[w]
    row["mean_steps"] = float(n_steps.mean())
    row["raw_ms_per_episode"] = 1e3 * raw / n_actions
    for w in workers:
        row[f"raw_over_batch_w{w}"] = raw / (row[f"s_w{w}"] * w)
    if len(workers) > 1:
        row["speedup"] = row[f"eps_per_s_w{workers[-1]}"] / row[f"eps_per_s_w{workers[0]}"]
    env.close()
    return row


def main(argv: list[str] | None = None) -> int:
    import phyplan_envs
    from phyplan_envs.batch import close_pools, default_workers

    p = argparse.ArgumentParser(prog="python -m benchmarks.batch_speed", description=__doc__.split("\n\n")[0])
    p.add_argument("--tasks", nargs="+", default=list(phyplan_envs.TASKS), choices=list(phyplan_envs.TASKS))
    p.add_argument("--actions", type=int, default=512, help="actions per task (default 512)")
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker counts to time (default 1 2)")
    p.add_argument("--repeats", type=int, default=3, help="timings per point; the best is kept (default 3)")
    p.add_argument("--seed", type=int, default=0, help="context seed and action seed (default 0)")
    p.add_argument("--out", default=None, help="also write the rows to this CSV file")
    p.add_argument("--rollout", action="store_true",
                   help="instead, measure the rejected mujoco.rollout design (model copies, per-step cost, "
                        "bit-identity of split rollouts) on 32 episodes x 400 steps per task")
    args = p.parse_args(argv)
    if args.rollout:
        print(f"load average before: {_load()}")
        print("| task | MjModel copy ms/episode | rollout us/step (1 thread) | one call = env | two calls = env |")
        print("|---|---|---|---|---|")
        for task in args.tasks:
            r = rollout_candidate(task, 32, 400, 1, args.seed)
            print(f"| {task} | {r['model_copy_ms']:.1f} | {r['rollout_us_per_step']:.2f} | {r['one_call_identical']} "
                  f"| {r['split_identical']} |")
        print(f"load average after: {_load()}")
        return 0
    if args.actions < 8 or args.repeats < 1 or min(args.workers) < 1:
        p.error("--actions must be >= 8, --repeats and --workers >= 1")
    workers = sorted(set(args.workers))

    print(f"cores available: {default_workers()}; load average before: {_load()}")
    control = control_speedup(max(workers)) if len(workers) > 1 else None
    rows = []
    try:
        for task in args.tasks:
            rows.append(measure(task, args.actions, workers, args.repeats, args.seed))
        rss = _worker_rss(max(workers))
    finally:
        close_pools()
    head = ["task", "steps/ep", "raw ms/ep"] + [f"ep/s w={w}" for w in workers] + \
        (["speed-up"] if len(workers) > 1 else []) + [f"raw/batch w={w}" for w in workers]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        cells = [r["task"], f"{r['mean_steps']:.0f}", f"{r['raw_ms_per_episode']:.2f}"]
        cells += [f"{r[f'eps_per_s_w{w}']:.0f}" for w in workers]
        cells += [f"{r['speedup']:.2f}x"] if len(workers) > 1 else []
        cells += [f"{r[f'raw_over_batch_w{w}']:.2f}" for w in workers]
        print("| " + " | ".join(cells) + " |")
    if control is not None:
        control = (control + control_speedup(max(workers))) / 2                     # before and after the table
        print(f"control: {max(workers)} independent single-env processes at once ran {control:.2f}x the episodes/s of "
              f"one (what the machine gave, mean of before and after; mean speed-up / control = "
              f"{np.mean([r['speedup'] for r in rows]) / control:.2f})")
    print("warm-up (pool start, envs compiled in each worker) s: " + "; ".join(
        f"{r['task']} " + ", ".join(f"w={w} {r[f'warmup_s_w{w}']:.2f}" for w in workers) for r in rows))
    print(f"worker memory (RSS, each holding the {len(rows)} tasks' envs): {rss}")
    print(f"load average after: {_load()}")
    if args.out:
        with open(args.out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("MUJOCO_GL", "egl")
    sys.exit(main())
