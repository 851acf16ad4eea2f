"""LaunchBounce's design checks: the bounce off the placed wedge converges in the timestep and is not chaotic, and
the wedge is needed.

``--chaos``: 200 (``--actions``) random *bouncing* actions, i.e. actions whose ball meets the wedge (the pendulum's
plane and release angle uniform, the wedge's direction within N(0, 0.1 rad) of the plane, its distance U(0.2, 0.6)
m, its yaw uniform; drawn until the ball's path turns or rises before it lands, read from ``info["trajectory"]``),
each on the context of ``reset(seed=--seed + --seed-step * i)``: how far the landing moves when the timestep halves
and when every action dimension moves by each of ``--deltas``; the timestep rows also print their p90's 95%
bootstrap interval. ``--halvings K`` halves the timestep K times in turn, each row against the one before::

    python -m benchmarks.design_checks.launch_bounce --chaos --actions 200
    python -m benchmarks.design_checks.launch_bounce --chaos --actions 200 --seed 7310000 --seed-step 7919
    python -m benchmarks.design_checks.launch_bounce --chaos --actions 200 --seed 7310000 --seed-step 7919 \
        --halvings 2 --deltas --version 0      # the superseded v0 (0.5 ms), halved twice
    python -m benchmarks.design_checks.launch_bounce --chaos --actions 200 --seed 7310000 --seed-step 7919 --varied

``--varied`` measures LaunchBounceVaried (v1 at 0.0625 ms; ``--version 0``: v0 at 0.5 ms), each context's hidden
physics drawn from the test space.

``--wedge-needed N``: on N contexts, the oracle's search over the pendulum's two dimensions with the wedge kept out
of the ball's way (1.0 m out along pi/2, the far end of its range, beyond every direct flight): the best reward
without the wedge, and the share of contexts where it stays below 0.9::

    python -m benchmarks.design_checks.launch_bounce --wedge-needed 50 --seed 7310000 --seed-step 7919

``--reach N``: N random actions with the wedge in the flight's way (its direction within N(0, 0.08 rad) of the
swing plane, its distance U(0.2, 0.75) m): how far from the pedestal the landings behind the pendulum (y < 0) reach,
the figure LaunchBounceVaried's reach band scales::

    python -m benchmarks.design_checks.launch_bounce --reach 2000

``--reach-restitutions E [E ...]`` with ``--reach N``: the same on LaunchBounceVaried with the nominal bob and
each ball-wedge restitution E (``reset(options={"physics": ...})``), next to the far end of the varied goal
sampler's reach band at that physics::

    python -m benchmarks.design_checks.launch_bounce --reach 300 --reach-restitutions 0.4 0.55 0.7 0.8 0.9 0.99

``--pedestal N``: N bouncing actions (drawn as for ``--chaos``): the share whose simulated ball comes back to the
pedestal's column after it has left it (its centre within the ball's radius and :data:`RETURN_MARGIN` of the
column's sides, below its top), how many of those the composed chain meets the column on (no prediction: the task
describes the column as an obstacle, which no skill bounces off), and the chain's mean landing error on the rest
of them and on the others::

    python -m benchmarks.design_checks.launch_bounce --pedestal 200 --seed 7310000 --seed-step 7919

Figures: docs/composition.md.
"""
from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np

from benchmarks.design_checks import seeds as seeding
from benchmarks.design_checks.chaos import halved, print_table
from phyplan_envs import env_id

ID = env_id("launch-bounce")   # the checks run the current version (LaunchBounceEnv)

TURN = 0.02          # rad: the ball's horizontal heading changed by more than this in flight: it met the wedge
RISE = 0.002         # m: or its centre rose by more than this
LEFT = 0.15          # m: a ball this far from the pedestal's axis has left it
RETURN_MARGIN = 0.005  # m: a ball back within its radius and this of the column's sides meets the column


def bounced(trajectory: np.ndarray) -> bool:
    """Whether a recorded flight (rows ``t, x, y, z``) met something before it landed: its horizontal heading turned
    or its centre rose (a free flight off the pedestal keeps its heading and only falls)."""
    p = np.asarray(trajectory, dtype=np.float64)[:, 1:]
    moving = np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1) > 1e-6
    steps = np.diff(p[:, :2], axis=0)[moving]
    if len(steps) < 2:
        return False
    heading = np.unwrap(np.arctan2(steps[:, 1], steps[:, 0]))
    rise = np.max(p[1:, 2] - np.minimum.accumulate(p[:-1, 2]))
    return bool(np.ptp(heading) > TURN or rise > RISE)


def bouncing_actions(env, n: int, seed: int, context_seeds) -> np.ndarray:
    """``n`` random actions whose ball meets the wedge on their contexts (module docstring)."""
    rng = np.random.default_rng(seed)
    lo, hi = env.action_low, env.action_high
    out = []
    for s in context_seeds[:n]:
        while True:
            a = lo + (hi - lo) * rng.random(len(lo))
            a[3] = np.clip(a[0] + rng.normal(0.0, 0.1), lo[3], hi[3])
            a[2] = rng.uniform(0.2, 0.6)
            env.reset(seed=int(s), options={"record_trajectory": True})
            if bounced(env.step(a)[4]["trajectory"]):
                out.append(a)
                break
    return np.array(out)


def landings(env, acts, context_seeds, delta: float = 0.0) -> np.ndarray:
    hi = env.action_high
    out = []
    for s, a in zip(context_seeds, acts):
        env.reset(seed=int(s))
        out.append(env.step(np.minimum(a + delta, hi))[4]["final_pos"])
    return np.array(out)


def chaos(n: int, seed: int, context_seeds, deltas, halvings: int = 1, version: int = 1,
          varied: bool = False) -> dict[str, np.ndarray]:
    """Per change, how far (m) each of ``n`` bouncing actions' landing moves: each of ``deltas`` on every action
    dimension, and the timestep halved ``halvings`` times in turn (each row against the one before it; the later
    rows show whether the landing converges at a finer timestep than the task's); on LaunchBounce-v``version``, or
    with ``varied`` on LaunchBounceVaried-v``version`` with each context's physics drawn from the test space."""
    from phyplan_envs.tasks.launch_bounce import LaunchBounceEnv
    from phyplan_envs.tasks.launch_bounce_v0 import LaunchBounceEnvV0
    from phyplan_envs.tasks.varied import LaunchBounceVariedEnv
    from phyplan_envs.tasks.varied_v0 import LaunchBounceVariedEnvV0

    if version not in (0, 1):
        raise ValueError(f"version must be 0 or 1, got {version}")
    versions = (LaunchBounceVariedEnvV0, LaunchBounceVariedEnv) if varied else (LaunchBounceEnvV0, LaunchBounceEnv)
    task_cls = versions[version]
    kwargs = {"physics_space": "test"} if varied else {}
    env = task_cls(with_panda=False, **kwargs)
    acts = bouncing_actions(env, n, seed, context_seeds)
    base = landings(env, acts, context_seeds)
    moves = {f"delta {d:g}": np.linalg.norm(landings(env, acts, context_seeds, d) - base, axis=1) for d in deltas}
    cls, coarse = task_cls, base
    for k in range(halvings):
        cls = halved(cls, varied=varied)
        fine = landings(cls(with_panda=False, **kwargs), acts, context_seeds)
        name = "timestep halved" if k == 0 else f"timestep {1e3 * cls.timestep * 2:g} -> {1e3 * cls.timestep:g} ms"
        moves[name] = np.linalg.norm(fine - coarse, axis=1)
        coarse = fine
    return moves


def p90_interval(moves: np.ndarray, draws: int = 2000, seed: int = 0) -> tuple[float, float]:
    """A 95% bootstrap interval (percentile method, ``draws`` resamples of ``default_rng(seed)``) of the p90 of
    ``moves``: how far a p90 over this many actions is from the p90 of the population they are drawn from."""
    rng = np.random.default_rng(seed)
    p90 = np.percentile(rng.choice(moves, size=(draws, len(moves))), 90, axis=1)
    lo, hi = np.percentile(p90, [2.5, 97.5])
    return float(lo), float(hi)


def wedge_needed(n: int, context_seeds, budget: int) -> np.ndarray:
    """The best reward without the wedge (the oracle's search over phi and theta; the wedge out of the way)
    on each context."""
    import gymnasium as gym

    import phyplan_envs
    from phyplan_agents import Simulator, TaskInfo
    from phyplan_agents.oracle import OracleAgent

    env = gym.make(phyplan_envs.env_id("launch-bounce")).unwrapped
    sim_env = gym.make(phyplan_envs.env_id("launch-bounce")).unwrapped
    away = np.array([1.0, math.pi / 2, 0.0])          # the wedge's far corner: off every direct flight's path
    info = TaskInfo.from_env(env)
    two = dataclasses.replace(info, action_names=info.action_names[:2], action_low=info.action_low[:2],
                              action_high=info.action_high[:2])
    best = []
    for s in context_seeds[:n]:
        obs, inf = env.reset(seed=int(s))
        agent = OracleAgent(budget=budget)
        agent.setup(two, seed=0)
        sim = Simulator(sim_env, inf["context"])
        agent.begin_context(obs, inf, _Padded(sim, away))
        a = np.concatenate([agent.act(), away])
        env.reset(options={"context": inf["context"]})
        best.append(env.step(a)[1])
    return np.array(best)


class _Padded:
    """A simulator of the first two action dimensions: the wedge's three appended."""

    def __init__(self, sim, tail):
        self.sim, self.tail = sim, np.asarray(tail)

    def evaluate(self, action):
        return self.sim.evaluate(np.concatenate([np.asarray(action, dtype=np.float64), self.tail]))

    def evaluate_batch(self, actions):
        a = np.asarray(actions, dtype=np.float64)
        return self.sim.evaluate_batch(np.concatenate([a, np.tile(self.tail, (len(a), 1))], axis=1))

    def __getattr__(self, name):
        return getattr(self.sim, name)


def reach(n: int, seed: int, physics: dict[str, float] | None = None) -> np.ndarray:
    """The distances (m) from the pedestal of the landings behind the pendulum (y < 0) of ``n`` random actions with
    the wedge in the flight's way (module docstring), on the context of ``reset(seed=seed + i)``; with ``physics``
    (hidden values), on LaunchBounceVaried (its current version) under those values."""
    from phyplan_envs.tasks.launch_bounce import BALL_START, LaunchBounceEnv
    from phyplan_envs.tasks.varied import LaunchBounceVariedEnv

    env = (LaunchBounceEnv if physics is None else LaunchBounceVariedEnv)(with_panda=False)
    options = {} if physics is None else {"physics": physics}
    rng = np.random.default_rng(seed)
    lo, hi = env.action_low, env.action_high
    out = []
    for i in range(n):
        a = lo + (hi - lo) * rng.random(len(lo))
        a[3] = np.clip(a[0] + rng.normal(0.0, 0.08), lo[3], hi[3])
        a[2] = rng.uniform(0.2, 0.75)
        env.reset(seed=seed + i, options=dict(options))
        xy = env.step(a)[4]["final_pos"][:2] - BALL_START[:2]
        if xy[1] < 0:
            out.append(float(np.linalg.norm(xy)))
    return np.array(out)


def print_reach_varied(n: int, seed: int, restitutions) -> None:
    """The reach behind on LaunchBounceVaried (its current version) at the nominal bob and each ball-wedge
    restitution, with the far end of the goal sampler's reach band there."""
    from phyplan_envs.tasks.varied import LaunchBounceVariedEnv

    hidden = LaunchBounceVariedEnv(with_panda=False).hidden
    nominal = {p.name: p.nominal for p in hidden.parameters}
    print(f"\n{env_id('launch-bounce-varied')}, nominal bob, {n} actions of default_rng({seed}) per restitution: "
          "landings behind the pendulum (y < 0), distance from the pedestal (m)")
    print("| ball-wedge restitution | behind | median | p95 | max | reach band's far end |")
    print("|---|---|---|---|---|---|")
    for e in restitutions:
        physics = {**nominal, "wedge_restitution": float(e)}
        d = reach(n, seed, physics)
        far = hidden.reach_band(physics)[1]
        if len(d) == 0:
            print(f"| {e:g} | 0 | - | - | - | {far:.3f} |")
            continue
        print(f"| {e:g} | {len(d)} | {np.median(d):.3f} | {np.percentile(d, 95):.3f} | {d.max():.3f} | {far:.3f} |")


def comes_back(facts, trajectory: np.ndarray) -> bool:
    """Whether a recorded flight (rows ``t, x, y, z``) comes back to the pedestal's column after it has left it:
    its centre within the ball's radius and :data:`RETURN_MARGIN` of the column's sides, below the column's top."""
    from phyplan_envs import assets

    path = np.asarray(trajectory, dtype=np.float64)[:, 1:]
    rel = path[:, :2] - np.asarray(facts.pedestal_xy)
    away = np.linalg.norm(rel, axis=1) > LEFT
    if not away.any():
        return False
    later = slice(int(np.argmax(away)), None)
    gap = np.linalg.norm(np.maximum(np.abs(rel[later]) - assets.PEDESTAL_HALF, 0.0), axis=1)
    low = path[later, 2] < facts.pedestal_height + facts.ball_radius
    return bool(np.any((gap < facts.ball_radius + RETURN_MARGIN) & low))


def pedestal_returns(n: int, seed: int, context_seeds) -> dict[str, np.ndarray]:
    """Per bouncing action: whether its simulated ball comes back to the pedestal's column, and the composed
    chain's landing error (NaN where it has no prediction)."""
    import torch

    from phyplan_agents.phyplan.agent import load_default_skills
    from phyplan_agents.phyplan.composer import ComposedChain
    from phyplan_agents.phyplan.fastnet import fast_skills
    from phyplan_envs.tasks.launch_bounce import LaunchBounceEnv

    env = LaunchBounceEnv(with_panda=False)
    acts = bouncing_actions(env, n, seed, context_seeds)
    chain, skills = ComposedChain("launch-bounce"), fast_skills(load_default_skills())
    back, err = [], []
    for s, a in zip(context_seeds, acts):
        env.reset(seed=int(s), options={"record_trajectory": True})
        info = env.step(a)[4]
        back.append(comes_back(env.facts, info["trajectory"]))
        env.reset(seed=int(s))
        pred = chain.rollout(None, torch.as_tensor(a[None], dtype=torch.float32), skills)[0].numpy()
        err.append(float(np.linalg.norm(pred - info["final_pos"][:2])))
    env.close()
    return {"back": np.array(back), "error_m": np.array(err)}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.design_checks.launch_bounce", description=__doc__.split(
        "\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--chaos", action="store_true", help="timestep and action-change sensitivity of bouncing actions")
    p.add_argument("--actions", type=int, default=200, help="bouncing actions for --chaos (default 200)")
    p.add_argument("--deltas", nargs="*", type=float, default=[1e-8, 1e-6, 1e-4],
                   help="action changes for --chaos (default 1e-8 1e-6 1e-4)")
    p.add_argument("--version", type=int, choices=(0, 1), default=1,
                   help="for --chaos: LaunchBounce's version (default 1, the current; 0: the superseded 0.5 ms one)")
    p.add_argument("--varied", action="store_true",
                   help="for --chaos: on LaunchBounceVaried (--version), each context's physics from the test space")
    p.add_argument("--halvings", type=int, default=1,
                   help="for --chaos: halve the timestep this many times in turn (default 1: the certificate)")
    p.add_argument("--wedge-needed", type=int, default=0, metavar="N",
                   help="contexts for the best reward without the wedge")
    p.add_argument("--reach", type=int, default=0, metavar="N", help="random actions for the reach behind")
    p.add_argument("--reach-restitutions", type=float, nargs="+", default=None, metavar="E",
                   help="with --reach: measure on LaunchBounceVaried at these ball-wedge restitutions")
    p.add_argument("--budget", type=int, default=200, help="the oracle's budget for --wedge-needed (default 200)")
    p.add_argument("--pedestal", type=int, default=0, metavar="N",
                   help="bouncing actions for the balls that come back to the pedestal's column")
    seeding.add_arguments(p)
    args = p.parse_args(argv)
    if not args.chaos and not args.wedge_needed and not args.reach and not args.pedestal:
        p.error("give --chaos, --wedge-needed N, --reach N and/or --pedestal N")
    if args.reach_restitutions is not None:
        if not args.reach:
            p.error("--reach-restitutions needs --reach N")
        bad = [e for e in args.reach_restitutions if not 0.0 < e <= 1.0]
        if bad:
            p.error(f"--reach-restitutions must lie in (0, 1], got {bad}")
    first = args.seed or 0
    if args.halvings < 1:
        p.error(f"--halvings must be >= 1, got {args.halvings}")
    if args.varied and not args.chaos:
        p.error("--varied needs --chaos")
    if args.chaos:
        seeding.check(p, args, args.actions, "--actions")
        contexts = seeding.seed_list(first, args.seed_step, args.actions)
        moves = chaos(args.actions, first, contexts, args.deltas, args.halvings, args.version, args.varied)
        name = (f"PhyPlan/LaunchBounceVaried-v{args.version} (test physics)" if args.varied
                else f"PhyPlan/LaunchBounce-v{args.version}")
        print_table(f"{name}: landing moves, mm ({args.actions} bouncing actions of default_rng({first}) on "
                    f"the contexts of {seeding.describe(contexts)})", moves)
        for name, m in moves.items():
            if name.startswith("timestep"):
                lo, hi = p90_interval(m)
                print(f"{name}: p90 {1e3 * np.percentile(m, 90):.2f} mm, 95% bootstrap interval "
                      f"{1e3 * lo:.2f}-{1e3 * hi:.2f} mm")
    if args.reach:
        seeding.check(p, args, args.reach, "--reach")
        if args.reach_restitutions is None:
            d = reach(args.reach, first)
            print(f"\n{ID}: {len(d)} of {args.reach} landings behind the pendulum (y < 0); their distance "
                  f"from the pedestal, m: median {np.median(d):.3f}, p90 {np.percentile(d, 90):.3f}, p95 "
                  f"{np.percentile(d, 95):.3f}, p99 {np.percentile(d, 99):.3f}, max {d.max():.3f}")
        else:
            print_reach_varied(args.reach, first, args.reach_restitutions)
    if args.pedestal:
        seeding.check(p, args, args.pedestal, "--pedestal")
        contexts = seeding.seed_list(first, args.seed_step, args.pedestal)
        r = pedestal_returns(args.pedestal, first, contexts)
        back, err = r["back"], r["error_m"]
        ok = np.isfinite(err)

        def mean_cm(sel):
            return f"{100 * err[sel & ok].mean():.1f} cm" if (sel & ok).any() else "-"

        print(f"\n{ID} ({args.pedestal} bouncing actions on {seeding.describe(contexts)}): "
              f"{int(back.sum())} ({back.mean():.1%}) come back to the pedestal's column; the composed chain has no "
              f"prediction on {int((back & ~ok).sum())} of those and on {int((~back & ~ok).sum())} of the others; "
              f"its mean landing error on the rest of those {mean_cm(back)}, on the others {mean_cm(~back)}")
    if args.wedge_needed:
        seeding.check(p, args, args.wedge_needed, "--wedge-needed")
        contexts = seeding.seed_list(first, args.seed_step, args.wedge_needed)
        best = wedge_needed(args.wedge_needed, contexts, args.budget)
        print(f"\n{ID} without the wedge ({seeding.describe(contexts)}, oracle budget {args.budget}): best "
              f"reward median {np.median(best):.3f}, max {best.max():.3f}; below 0.9 on {np.mean(best < 0.9):.0%} "
              f"of {len(best)} contexts")


if __name__ == "__main__":
    main()
