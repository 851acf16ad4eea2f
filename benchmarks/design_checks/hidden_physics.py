"""Design checks of the varied tasks' hidden physics: the contacts obey the set values, the physics is converged in
the timestep, Bounce's range is monotone in the drop height, and what an episode costs.

    python -m benchmarks.design_checks.hidden_physics               # everything (a few minutes on one core)
    python -m benchmarks.design_checks.hidden_physics --only restitution friction --n 200
    python -m benchmarks.design_checks.hidden_physics --only convergence --tasks slide bridge --n 200
    python -m benchmarks.design_checks.hidden_physics --only convergence --n 200 --seed 7310000 --seed-step 7919
    python -m benchmarks.design_checks.hidden_physics --only rebound-phase

``rebound-phase`` (no sampling: a fixed grid) measures how much the rebound of PaddlesVaried-v0-v2's impact pair
depends on where in a timestep the ball arrives (v3's exact
impacts do not: ``tests/test_impacts.py``): on the low-restitution bounce skill's board
(:class:`phyplan_envs.skill_scenes.bounce_general_low.LowBounceScene`, the varied pair) at 45 degrees, the outgoing
normal speed over 25 arrival phases, at the task's 0.5 ms and at 0.25 and 0.125 ms. With ``--stiffness K ...`` it
measures the same at 0.5 ms for the pair's other stiffnesses K (a softer contact lasts longer), with the mean contact
time::

    python -m benchmarks.design_checks.hidden_physics --only rebound-phase --stiffness 200000 50000 20000 5000

The slide and bridge rows check the current versions (``SlideVaried-v1``, ``BridgeVaried-v1``). Sample i of a check
is the context ``reset(seed=S + STEP * i)`` (``--seed``, ``--seed-step``; :mod:`.seeds`) with the physics of the
space in ``--spaces`` and the i-th random action of ``default_rng(S)``; ``--seed 7310000 --seed-step 7919`` are
contexts outside every split. Each table's header names its samples; the numbers in the docs come from this command.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

import phyplan_envs  # noqa: F401  (registers the ids)
from benchmarks.design_checks import contacts
from benchmarks.design_checks import seeds as seeding
from benchmarks.design_checks.contacts import CLASSES, make, random_actions
from phyplan_envs import hidden_physics as hp

DEFAULT_SPACES = {"restitution": ("train", "test"), "friction": ("train", "test"), "convergence": ("test",),
                  "cost": ("train",), "nominal": ("test",)}
"""The physics spaces a check samples unless ``--spaces`` says otherwise."""
DEFAULT_SEED = {"nominal": 200_000}   # the first test contexts; the other checks start at seed 0


# ============================================================================================ convergence
def convergence(task: str, seeds: list[int], space: str = "test", timestep: float | None = None,
                version: int | None = None) -> np.ndarray:
    """How far the end point moves (m) when the timestep (default the task's) halves, per sample: the contexts
    ``seeds`` in physics ``space`` and the random actions of ``default_rng(seeds[0])``; ``version=0``: the
    superseded v0 of Slide or Bridge."""
    dt = CLASSES[task].timestep if timestep is None else float(timestep)
    coarse = make(task, timestep=dt, physics_space=space, version=version)
    fine = make(task, timestep=dt / 2, physics_space=space, version=version)
    acts = random_actions(coarse, np.random.default_rng(seeds[0]), len(seeds))
    moves = []
    for s, a in zip(seeds, acts):
        ends = []
        for env in (coarse, fine):
            env.reset(seed=s)
            ends.append(env.step(a)[4]["final_pos"][:2])
        moves.append(float(np.linalg.norm(ends[0] - ends[1])))
    coarse.close()
    fine.close()
    return np.array(moves)


def bounce_monotonicity(restitution: float, step: float = 0.0025, yaw: float = -1.0) -> tuple[int, float, float]:
    """(number of decreases, worst decrease m, range span m) of the landing range over drop heights 0.5-1.5 m."""
    env = make("bounce")
    ranges = []
    for h in np.arange(0.5, 1.5 + 1e-9, step):
        env.reset(seed=0, options={"physics": {"restitution": restitution}})
        ranges.append(float(np.linalg.norm(env.step(np.array([yaw, h]))[4]["final_pos"][:2])))
    env.close()
    dr = np.diff(ranges)
    return int(np.sum(dr < 0)), float(min(dr.min(), 0.0)), float(ranges[-1] - ranges[0])


def episode_cost(task: str, seeds: list[int], space: str = "train") -> float:
    """Mean CPU milliseconds of reset + step over the contexts ``seeds`` (physics ``space``) and random actions (no
    Panda; CPU time, so that a loaded machine does not inflate it; each context's restitution calibration included)."""
    env = make(task, physics_space=space)
    acts = random_actions(env, np.random.default_rng(seeds[0]), len(seeds))
    hp.calibrated_damping.cache_clear()     # the calibration is paid as by a fresh process (not by an earlier check)
    t0 = time.process_time()
    for s, a in zip(seeds, acts):
        env.reset(seed=s)
        env.step(a)
    env.close()
    return (time.process_time() - t0) / len(seeds) * 1000


def nominal_planner_regret(task: str, seeds: list[int], space: str = "test", attempts: int = 5,
                           budget: int = 200, version: int | None = None) -> np.ndarray:
    """Regret (``(len(seeds), attempts)``: after 1 .. ``attempts`` attempts) of a planner that ignores the hidden
    physics but is otherwise perfect: the oracle's search run on the simulator with the *nominal* values
    (:func:`phyplan_envs.hidden_physics.nominal`), its ``attempts`` actions scored under the context's true physics;
    the contexts ``seeds`` in physics ``space`` (default: the first test contexts). What the range requirement "an
    agent ignoring the hidden physics has regret >= 0.10 after 5 attempts" is checked against (``phyplan-nogp`` adds
    its skill models' errors on top). ``version=0``: the superseded v0 of Slide or Bridge."""
    import gymnasium as gym

    from phyplan_agents import Simulator, TaskInfo
    from phyplan_agents.oracle import OracleAgent

    nominal = hp.nominal(task)

    class NominalSimulator(Simulator):
        def evaluate(self, action):
            self._env.reset(options={"context": self._context, "physics": nominal})
            _, reward, _, _, info = self._env.step(np.asarray(action, dtype=np.float64))
            self.calls += 1
            return float(reward), info

        def evaluate_batch(self, actions):
            out = [self.evaluate(a) for a in np.atleast_2d(actions)]
            return np.array([r for r, _ in out]), [i for _, i in out]

    env_id = phyplan_envs.env_id(f"{task}-varied")
    if version is not None:
        env_id = env_id.rsplit("-v", 1)[0] + f"-v{version}"
    env = gym.make(env_id, with_panda=False, physics_space=space)
    sim_env = gym.make(env_id, with_panda=False, physics_space=space)
    regrets = []
    for seed in seeds:
        agent = OracleAgent(budget=budget)
        agent.setup(TaskInfo.from_env(env), seed=0)
        obs, info = env.reset(seed=seed)
        agent.begin_context(obs, info, NominalSimulator(sim_env, info["context"]))
        best, curve = -math.inf, []
        for _ in range(attempts):
            env.reset(options={"context": info["context"]})
            action = agent.act()
            _, reward, _, _, step_info = env.step(action)
            agent.observe(action, reward, step_info)
            best = max(best, reward)
            curve.append(max(0.0, 1.0 - best))
        regrets.append(curve)
    env.close()
    sim_env.close()
    return np.array(regrets)


# ============================================================================================ rebound phase
def rebound_phases(timestep: float, restitution: float, normal_speed: float, phases: int = 25,
                   v_down: float = 3.0, stiffness: float | None = None, contact: bool = False):
    """The outgoing normal speed (m/s) of PaddlesVaried's impact pair (restitution calibrated at ``timestep``) for
    an arrival at ``normal_speed`` into a 45-degree board with ``v_down`` along it, at ``phases`` evenly spaced
    arrival phases within a timestep. ``stiffness``: the pair's K (default the task's,
    ``hidden_physics.INCLINE_STIFFNESS``); with ``contact`` also the mean contact time (s)."""
    from phyplan_envs.skill_scenes.bounce_general_low import LowBounceScene

    scene = LowBounceScene("varied", stiffness)
    scene.scene.model.opt.timestep = float(timestep)       # set_incline calibrates the pair at this timestep
    v = np.array([v_down, 0.0, -float(normal_speed)])
    runs = [scene.bounce(restitution, math.pi / 4, v, u) for u in np.linspace(0.02, 0.98, phases)]
    out = np.array([r["v_out"][2] for r in runs])
    return (out, float(np.mean([r["contact_s"] for r in runs]))) if contact else out


def _mm(x: float) -> str:
    return f"{x * 1000:.2f}"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.design_checks.hidden_physics",
                                 description=__doc__.split("\n")[0])
    checks = ["restitution", "friction", "convergence", "monotone", "cost", "nominal", "rebound-phase"]
    ap.add_argument("--only", nargs="+", choices=checks, default=checks)
    ap.add_argument("--n", type=int, default=20,
                    help="samples (contexts with a random action) per task and space of every check but monotone "
                         "(default 20)")
    ap.add_argument("--tasks", nargs="+", choices=list(CLASSES), default=list(CLASSES),
                    help="the varied tasks to check (default all four; friction: slide and bridge only)")
    ap.add_argument("--spaces", nargs="+", choices=hp.SPACES, default=None,
                    help="physics spaces of the samples (default: " + "; ".join(
                        f"{c} {' '.join(s)}" for c, s in DEFAULT_SPACES.items()) + ")")
    ap.add_argument("--yaws", nargs="+", type=float, default=[-1.0],
                    help="wedge yaws (rad) of the monotone check (default -1.0)")
    ap.add_argument("--timestep", type=float, default=None, metavar="DT",
                    help="the convergence check halves this timestep (s; default the task's, 0.0005)")
    ap.add_argument("--stiffness", type=float, nargs="+", default=None, metavar="K",
                    help="rebound-phase: the impact pair at these stiffnesses K (the task's: 2e5) at 0.5 ms, a study "
                         "of softer contacts")
    ap.add_argument("--version", type=int, choices=(0, 1), default=1,
                    help="the convergence and nominal checks on SlideVaried-vN / BridgeVaried-vN (default 1; 0: the "
                         "disc puck)")
    seeding.add_arguments(ap, default_seed="0; nominal: 200000, the first test contexts")
    args = ap.parse_args(argv)
    seeding.check(ap, args, args.n, "--n")
    if args.timestep is not None and not 1e-5 <= args.timestep <= 0.002:
        ap.error(f"--timestep must be in [1e-5, 0.002] s, got {args.timestep}")
    if args.stiffness is not None and (args.only != ["rebound-phase"]
                                       or not all(1e3 <= k <= 1e7 for k in args.stiffness)):
        ap.error(f"--stiffness needs --only rebound-phase and values in [1e3, 1e7], got {args.stiffness}")
    if args.version == 0 and (not set(args.only) <= {"convergence", "nominal"}
                              or not set(args.tasks) <= set(contacts.CLASSES_V0)):
        ap.error("--version 0 needs --only convergence or nominal and --tasks among slide bridge (the v0 disc puck)")

    def samples(check: str) -> list[tuple[str, list[int]]]:
        first = args.seed if args.seed is not None else DEFAULT_SEED.get(check, 0)
        seeds = seeding.seed_list(first, args.seed_step, args.n)
        actions = "" if check == "nominal" else f", random actions of default_rng({first})"
        print(f"samples per task and space: contexts of {seeding.describe(seeds)}{actions}")
        return [(space, seeds) for space in (args.spaces or DEFAULT_SPACES[check])]

    tasks = list(args.tasks)
    if "restitution" in args.only:
        print("set vs measured restitution, |measured - set| per task and space: as the task runs, and with gravity "
              "off during the impact")
        runs = samples("restitution")
        print("| task | space | samples | max | p90 | mean (signed) | set e at the max | max, no gravity | "
              "p90, no gravity |")
        print("|---|---|---|---|---|---|---|---|---|")
        for t in tasks:
            for space, seeds in runs:
                r = contacts.restitution_summary(contacts.restitution_samples(t, seeds, space))
                print(f"| {t} | {space} | {r['n']} | {r['max']:.4f} | {r['p90']:.4f} | "
                      f"{r['mean']:+.4f} | {r['e_at_max']:.3f} | {r['max_no_gravity']:.4f} | "
                      f"{r['p90_no_gravity']:.4f} |", flush=True)
    friction_tasks = [t for t in tasks if t in ("slide", "bridge")]
    if "friction" in args.only and friction_tasks:
        print("\nset vs measured friction (deceleration / g in each surface's window), the block's share of window "
              "steps out of contact with the surface and its rise above its rest height on it")
        runs = samples("friction")
        print("| task | surface | space | samples | max abs. error | p90 | out of contact median / max | "
              "rise p90 / max (mm) |")
        print("|---|---|---|---|---|---|---|---|")
        for t in friction_tasks:
            for space, seeds in runs:
                for surface, rows in contacts.friction_samples(t, seeds, space).items():
                    r = contacts.friction_summary(rows)
                    if not r["n"]:
                        print(f"| {t} | {surface} | {space} | 0 | - | - | - | - |")
                        continue
                    print(f"| {t} | {surface} | {space} | {r['n']} | {r['max']:.4f} | "
                          f"{r['p90']:.4f} | {r['out_median']:.0%} / {r['out_max']:.0%} | "
                          f"{_mm(r['rise_p90'])} / {_mm(r['rise_max'])} |", flush=True)
    if "convergence" in args.only:
        print(f"\nend point moved when dt halves, mm (v{args.version} of slide and bridge)")
        runs = samples("convergence")
        print("| task | space | dt ms | median | p90 | max |")
        print("|---|---|---|---|---|---|")
        for t in tasks:
            for space, seeds in runs:
                mv = convergence(t, seeds, space, args.timestep, args.version)
                dt = CLASSES[t].timestep if args.timestep is None else args.timestep
                print(f"| {t} | {space} | {dt * 1000:g} -> {dt * 500:g} | {_mm(np.median(mv))} | "
                      f"{_mm(np.percentile(mv, 90))} | {_mm(mv.max())} |", flush=True)
    if "monotone" in args.only and "bounce" in tasks:
        print("\nBounce landing range over drop heights 0.5-1.5 m in 2.5 mm steps (deterministic: no seed)")
        print("| yaw | e | decreases | worst mm | span m |")
        print("|---|---|---|---|---|")
        for yaw in args.yaws:
            for e in (0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.99):
                k, worst, span = bounce_monotonicity(e, yaw=yaw)
                print(f"| {yaw:g} | {e:.2f} | {k} | {worst * 1000:.2f} | {span:.3f} |", flush=True)
    if "nominal" in args.only:
        print(f"\nregret of a planner using the nominal physics (oracle search on the nominal simulator; "
              f"v{args.version} of slide and bridge)")
        runs = samples("nominal")
        print("| task | space | mean@1 | mean@5 | median@5 | share@5 >= 0.10 |")
        print("|---|---|---|---|---|---|")
        for t in tasks:
            for space, seeds in runs:
                r = nominal_planner_regret(t, seeds, space, version=args.version)
                print(f"| {t} | {space} | {r[:, 0].mean():.3f} | {r[:, -1].mean():.3f} | "
                      f"{np.median(r[:, -1]):.3f} | {np.mean(r[:, -1] >= 0.10):.2f} |", flush=True)
    if "rebound-phase" in args.only and args.stiffness:
        print("\nPaddlesVaried's impact pair at other stiffnesses K: outgoing normal speed over 25 arrival phases "
              "(45-degree board, 3 m/s along it) at 0.5 ms: mean m/s, spread (standard deviation / mean) and the "
              "mean contact time")
        print("| K | restitution | normal speed in m/s | mean out | spread | contact ms |")
        print("|---|---|---|---|---|---|")
        for k in args.stiffness:
            for e in (0.05, 0.15, 0.25):
                for vn in (1.0, 3.0, 5.0):
                    try:
                        out, c_s = rebound_phases(0.0005, e, vn, stiffness=k, contact=True)
                    except RuntimeError:          # so soft that the ball does not come back within the window
                        print(f"| {k:g} | {e:.2f} | {vn:g} | no rebound at some phase | | |", flush=True)
                        continue
                    print(f"| {k:g} | {e:.2f} | {vn:g} | {out.mean():.3f} | {out.std() / out.mean():.1%} | "
                          f"{c_s * 1000:.1f} |", flush=True)
    elif "rebound-phase" in args.only:
        print("\nPaddlesVaried's impact pair: outgoing normal speed over 25 arrival phases (45-degree board, 3 m/s "
              "along it): mean m/s and spread (standard deviation / mean)")
        print("| timestep ms | restitution | normal speed in m/s | mean out | spread |")
        print("|---|---|---|---|---|")
        for dt in (0.0005, 0.00025, 0.000125):
            for e in (0.05, 0.15, 0.25):
                for vn in (1.0, 3.0, 5.0):
                    out = rebound_phases(dt, e, vn)
                    print(f"| {dt * 1000:g} | {e:.2f} | {vn:g} | {out.mean():.3f} | {out.std() / out.mean():.1%} |",
                          flush=True)
    if "cost" in args.only:
        print("\nCPU ms per episode (reset + step, no Panda, random contexts and actions)")
        runs = samples("cost")
        print("| task | space | ms |")
        print("|---|---|---|")
        for t in tasks:
            for space, seeds in runs:
                print(f"| {t} | {space} | {episode_cost(t, seeds, space):.1f} |",
                      flush=True)


if __name__ == "__main__":
    main()
