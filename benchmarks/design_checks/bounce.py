"""Bounce design check: the wedge's restitution and landing range, solvability of sampled contexts, episode time.

``python -m benchmarks.design_checks.bounce --measure`` steps single drops one physics step at a time and reports
the ball-incline contact (normal restitution, speed ratio, launch elevation, contact time, slide) and the landing
range per drop height; ``--solvability N`` runs the project's search on the real simulator
(:mod:`phyplan_agents.sim_search`, ``--budget`` calls) on the contexts of seeds ``--seed`` .. ``--seed + N - 1``;
``--time N`` the median wall time of N random episodes (contexts ``--seed`` .. ``--seed + N - 1``, actions of
``default_rng(--seed)``); ``--sawtooth`` the landing range over drop heights 0.5-1.5 m in 2.5 mm steps at the task's
timestep and at half of it (at each of ``--yaws``): how often it goes down as the height rises, and the restitution
per number of contact steps. The figures are quoted in :class:`phyplan_envs.tasks.bounce.BounceEnv`'s docstring and
docs/physics.md.
"""
from __future__ import annotations

import math

import numpy as np

from benchmarks.design_checks.chaos import halved
from phyplan_agents.sim_search import search
from phyplan_envs import assets
from phyplan_envs.tasks.bounce import DROP_XY, BounceEnv


def measure_bounce(env: BounceEnv, yaw: float, height: float) -> dict[str, float]:
    """One drop stepped one physics step at a time: restitution and launch of the ball-incline contact, landing.

    ``restitution`` is the ratio of the normal velocity components (incline normal) just after and just before the
    contact; ``speed_ratio`` the same for the speed; ``elevation`` the launch angle above horizontal (deg).
    """
    import mujoco

    env.reset(seed=0)
    env.release(np.array([yaw, height]))      # the set-up, as step's (the episode is then used up)
    m, d = env.model, env.data
    n = np.array([math.cos(yaw), math.sin(yaw), 1.0]) / math.sqrt(2)
    v_in = v_out = p_out = None
    t_in = t_out = 0
    prev = env.object_pos()
    for t in range(int(assets.MAX_SIM_TIME / m.opt.timestep)):
        v_before = env.object_vel()
        mujoco.mj_step(m, d)
        if v_in is None and d.ncon > 0:
            v_in, t_in = v_before, t
        elif v_in is not None and v_out is None and d.ncon == 0:
            v_out, t_out, p_out = env.object_vel(), t, env.object_pos()
        pos = env.object_pos()
        if pos[2] <= env.landing_height < prev[2]:
            f = (prev[2] - env.landing_height) / (prev[2] - pos[2])
            land = prev + f * (pos - prev)
            break
        prev = pos
    else:
        raise RuntimeError(f"the ball did not land (yaw {yaw}, height {height})")
    if v_in is None or v_out is None:
        raise RuntimeError(f"the ball never left the incline (yaw {yaw}, height {height})")
    horiz = math.hypot(v_out[0], v_out[1])
    return {
        "restitution": float(-np.dot(v_out, n) / np.dot(v_in, n)),
        "speed_ratio": float(np.linalg.norm(v_out) / np.linalg.norm(v_in)),
        "elevation_deg": math.degrees(math.atan2(v_out[2], horiz)),
        "contact_ms": (t_out - t_in) * m.opt.timestep * 1000,
        "slide_m": float(np.linalg.norm(p_out[:2] - DROP_XY)),
        "range_m": float(np.linalg.norm(land[:2] - DROP_XY)),
        "direction_err_rad": float(abs(math.remainder(math.atan2(land[1] - DROP_XY[1], land[0] - DROP_XY[0]) - yaw,
                                                      2 * math.pi))),
    }


def best_action(env: BounceEnv, context, budget: int = 200, target: float = 0.99,
                seed: int = 0) -> tuple[np.ndarray, float, int]:
    """The project's search on the real simulator (:func:`phyplan_agents.sim_search.search`: grid, model step, ES;
    the wedge yaw wraps around) with at most ``budget`` calls, stopping once the reward reaches ``target``.

    Returns (best action, its reward, simulator calls).
    """

    def simulate(a):
        env.reset(options={"context": context})
        _, reward, _, _, info = env.step(a)
        return reward, info

    res = search(simulate, env.action_low, env.action_high, budget=budget, stop_reward=target, seed=seed)
    return res.best_action, float(res.best_reward), res.calls


def sawtooth(env: BounceEnv, yaw: float, step: float = 0.0025) -> dict:
    """The landing range over drop heights 0.5-1.5 m in ``step`` steps at wedge yaw ``yaw``: decreases (count, worst
    m) and, per number of physics steps the ball-incline contact lasted, (drops, min and max restitution)."""
    rows = [measure_bounce(env, yaw, float(h)) for h in np.arange(0.5, 1.5 + 1e-9, step)]
    dr = np.diff([r["range_m"] for r in rows])
    by_steps: dict[int, list[float]] = {}
    for r in rows:
        by_steps.setdefault(int(round(r["contact_ms"] / 1000 / env.model.opt.timestep)), []).append(r["restitution"])
    return {"steps": len(dr), "decreases": int(np.sum(dr < 0)), "worst": float(min(dr.min(), 0.0)),
            "contact": {k: (len(v), min(v), max(v)) for k, v in sorted(by_steps.items())}}


def main(argv=None) -> None:
    import argparse
    import statistics
    import time

    p = argparse.ArgumentParser(prog="python -m benchmarks.design_checks.bounce",
                                description="Measure the Bounce task: restitution/landing and solvability.")
    p.add_argument("--measure", action="store_true", help="restitution and landing range per drop height")
    p.add_argument("--solvability", type=int, default=0, metavar="N",
                   help="the search (phyplan_agents.sim_search) on N contexts")
    p.add_argument("--budget", type=int, default=200, help="simulator calls per context for --solvability (200)")
    p.add_argument("--seed", type=int, default=0, help="first context seed (contexts use seeds seed..seed+N-1)")
    p.add_argument("--time", type=int, default=0, metavar="N", help="median wall time of N random episodes")
    p.add_argument("--sawtooth", action="store_true",
                   help="landing range vs drop height (2.5 mm steps) at the task's timestep and at half of it")
    p.add_argument("--yaws", type=float, nargs="+", default=[-1.0], help="wedge yaws of --sawtooth (default -1.0)")
    args = p.parse_args(argv)
    if args.seed < 0:
        p.error(f"--seed must be >= 0, got {args.seed}")
    for flag in ("solvability", "time"):
        if getattr(args, flag) < 0:
            p.error(f"--{flag} must be >= 0, got {getattr(args, flag)}")
    if args.budget < 4:
        p.error(f"--budget must be at least 4, got {args.budget}")
    env = BounceEnv()
    if args.measure:
        for h in (0.5, 0.75, 1.0, 1.25, 1.5):
            rows = [measure_bounce(env, yaw, h) for yaw in (-2.5, -1.0, 0.0, 1.5, 3.0)]
            agg = {k: (min(r[k] for r in rows), max(r[k] for r in rows)) for k in rows[0]}
            print(f"drop {h:.2f} m: " + ", ".join(f"{k} {a:.4g}..{b:.4g}" for k, (a, b) in agg.items()))
    if args.solvability:
        best, calls = [], []
        for i in range(args.solvability):
            env.reset(seed=args.seed + i)
            ctx = env.context
            a, r, c = best_action(env, ctx, budget=args.budget)
            best.append(r)
            calls.append(c)
            print(f"context seed {args.seed + i}: goal {np.round(ctx['goal'], 3).tolist()} best reward {r:.4f} "
                  f"at yaw {a[0]:.4f} rad, height {a[1]:.4f} m ({c} calls)")
        best = np.array(best)
        print(f"solvable (best reward >= 0.95): {np.mean(best >= 0.95):.1%} of {len(best)} contexts; "
              f"best reward min {best.min():.4f}, median {np.median(best):.4f}; "
              f"simulator calls per context median {statistics.median(calls)}")
    if args.sawtooth:
        print("landing range over drop heights 0.5-1.5 m in 2.5 mm steps (deterministic: no seed)")
        print("| dt ms | yaw | steps down | worst mm | contact steps: drops, restitution |")
        print("|---|---|---|---|---|")
        for cls in (BounceEnv, halved(BounceEnv)):
            e = cls()
            for yaw in args.yaws:
                r = sawtooth(e, yaw)
                contact = "; ".join(f"{k}: {n}, {lo:.3f}-{hi:.3f}" for k, (n, lo, hi) in r["contact"].items())
                print(f"| {e.model.opt.timestep * 1000:g} | {yaw:g} | {r['decreases']} of {r['steps']} | "
                      f"{r['worst'] * 1000:.1f} | {contact} |", flush=True)
            e.close()
    if args.time:
        rng = np.random.default_rng(args.seed)
        times = []
        for i in range(args.seed, args.seed + args.time):
            a = env.action_low + (env.action_high - env.action_low) * rng.random(2)
            t0 = time.perf_counter()
            env.reset(seed=i)
            env.step(a)
            times.append(time.perf_counter() - t0)
        print(f"episode wall time (reset + step, state obs): median {statistics.median(times) * 1000:.2f} ms "
              f"over {args.time} random episodes")


if __name__ == "__main__":
    main()
