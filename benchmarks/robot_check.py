"""Robot mode against the kinematic mode: same context and action, how far apart do the objects end, and what it costs.

For every task, ``--actions`` random actions (uniform in the action box, ``numpy.random.default_rng(--seed)``), each
on the context of ``reset(seed=i)``, run once in the kinematic mode (``robot=None``) and once in robot mode
(``robot="panda"``). Printed per task: the distance between the two final object positions (median, p90, max, and
the share within 1 cm), how many attempts the arm carried out (``robot_ok``) and why not, the release error (the
held point's distance from its target and its speed when the grasp let go) and the CPU seconds per attempt in both
modes (``time.process_time``: less disturbed by other processes on a shared machine than wall time), the two modes'
attempts interleaved. Before the timed attempts each mode runs one untimed attempt (the middle action): the first
robot-mode attempt of an env also plans the arm's ready pose and, the first of a process, imports mink and builds its
IK problem, a one-time cost printed on its own. Every context is also reset once first, untimed (a ``Varied``
context's contact calibration is cached per process: timed, it would fall on whichever mode met the context first).

    python -m benchmarks.robot_check --actions 50

``--reach-grid N`` instead plans (IK only, nothing simulated) every action of an N-point-per-dimension grid over
the action box and prints the actions the arm cannot reach: the reachable set of docs/robot.md.

    python -m benchmarks.robot_check --reach-grid 9

``--breakdown`` instead splits the CPU time of ``--actions`` robot-mode attempts per task: the set-up's physics
(the controller's physics steps), the IK solves, the task's ``robot_plan``, the controller's own Python (the rest of
the set-up) and the flight, against the kinematic attempt and its flight (docs/robot.md); the env's stage timer
(``env.stage_timer``) times them.

    python -m benchmarks.robot_check --breakdown --actions 20

``--sensitivity DELTA ...`` instead measures the kinematic mode's own sensitivity on the same actions: the share
whose final position moves by more than 1 cm when every action dimension moves by DELTA (rad or m), a floor under
the robot-mode mismatches (no release is exactly the kinematic one).

    python -m benchmarks.robot_check --sensitivity 1e-8 1e-6 1e-5 --actions 200

``--strips DIR`` writes, per task, a PNG strip of six frames of one robot-mode attempt (``STRIP_ACTIONS``,
context ``reset(seed=0)``): the README's pictures (``docs/img/robot_<task>.png``).

    python -m benchmarks.robot_check --strips docs/img
"""
from __future__ import annotations

import argparse
import collections
import json
import time

import numpy as np

from benchmarks.design_checks.chaos import random_actions


def check_task(task: str, actions: int, seed: int) -> dict:
    import gymnasium as gym

    import phyplan_envs

    kin = gym.make(phyplan_envs.env_id(task)).unwrapped
    rob = gym.make(phyplan_envs.env_id(task), robot="panda").unwrapped
    lo, hi = kin.action_space.low.astype(np.float64), kin.action_space.high.astype(np.float64)
    acts = random_actions(kin, actions, seed)
    # one untimed attempt per mode first (the middle action, on a context not used below): its one-time costs (the
    # first robot-mode attempt of a process imports mink and builds its IK problem; the arm's ready pose) are not a
    # per-attempt cost; the robot one is reported on its own
    mid = (lo + hi) / 2
    kin.reset(seed=actions)
    kin.step(mid)
    for i in range(actions):   # every context once, untimed: a Varied context's contact calibration is cached per
        kin.reset(seed=i)      # process and would otherwise be paid by whichever mode meets the context first
    t0 = time.process_time()
    rob.reset(seed=actions)
    rob.step(mid)
    first_robot = time.process_time() - t0
    rows = []
    t_kin = t_rob = 0.0
    for i, a in enumerate(acts):
        t0 = time.process_time()
        kin.reset(seed=i)
        _, r_kin, _, _, ik = kin.step(a)
        t1 = time.process_time()
        rob.reset(seed=i)
        _, r_rob, _, _, ir = rob.step(a)
        t2 = time.process_time()
        t_kin += t1 - t0
        t_rob += t2 - t1
        rows.append({"action": a.tolist(), "diff": float(np.linalg.norm(ir["final_pos"] - ik["final_pos"])),
                     "reward_kin": r_kin, "reward_robot": r_rob, "robot_ok": ir["robot_ok"],
                     "robot_reason": ir["robot_reason"], "setup_time": ir["robot_setup_time"],
                     "hold_error": ir["robot_hold_error"], "release_speed": ir["robot_release_speed"],
                     "arm_free": ir["robot_arm_free"]})
    kin.close()
    rob.close()
    diffs = np.array([r["diff"] for r in rows])
    ok = [r for r in rows if r["robot_ok"]]
    reasons = collections.Counter(r["robot_reason"].split(":")[0] for r in rows if not r["robot_ok"])
    return {"task": task, "actions": actions, "rows": rows,
            "median_mm": 1e3 * float(np.median(diffs)), "p90_mm": 1e3 * float(np.percentile(diffs, 90)),
            "max_mm": 1e3 * float(diffs.max()), "within_1cm": float(np.mean(diffs <= 0.01)),
            "robot_ok": len(ok), "failures": dict(reasons),
            "hold_error_mm_p90": 1e3 * float(np.percentile([r["hold_error"] for r in ok], 90)) if ok else float("nan"),
            "release_speed_mm_s_p90": (1e3 * float(np.percentile([r["release_speed"] for r in ok], 90))
                                       if ok else float("nan")),
            "setup_time_median": float(np.median([r["setup_time"] for r in ok])) if ok else float("nan"),
            "seconds_kin": t_kin / actions, "seconds_robot": t_rob / actions, "first_robot_seconds": first_robot}


def breakdown(task: str, actions: int, seed: int) -> dict:
    """CPU ms per attempt of each part of a robot-mode attempt (and of the kinematic attempt and its flight), timed
    by the env's stage timer (``env.stage_timer``: ``time.process_time`` seconds per stage; ``setup_physics`` is the
    arm controller's physics steps, the flight is in the env)."""
    import gymnasium as gym

    import phyplan_envs

    clock = time.process_time
    acc = collections.Counter()

    def stage_timer(stage, seconds, steps=0):
        acc[stage] += seconds
        if stage == "setup_physics":
            acc["setup_steps"] += steps

    out = {"task": task, "actions": actions}
    for mode in (None, "panda"):
        env = gym.make(phyplan_envs.env_id(task), robot=mode).unwrapped
        env.stage_timer = stage_timer
        acts = random_actions(env, actions, seed)
        env.reset(seed=0)
        env.step(acts[0])                                      # warm-up (first IK set-up, ready pose)
        acc.clear()
        for i, a in enumerate(acts):
            env.reset(seed=i)
            t = clock()
            env.step(a)
            acc["attempt"] += clock() - t
        env.close()
        per = {k: (v / actions if k == "setup_steps" else 1e3 * v / actions) for k, v in acc.items()}
        if mode is None:
            out["kin_attempt_ms"], out["kin_flight_ms"] = per["attempt"], per["flight"]
        else:
            out.update({f"{k}_ms" if k != "setup_steps" else k: v for k, v in per.items()})
            out["python_ms"] = per["setup"] - per["setup_physics"] - per["ik"]
    return out


STRIP_ACTIONS = {"launch": (0.6, 1.1), "slide": (0.9, 1.0), "bounce": (1.0, 1.2), "bridge": (0.5, 1.3, 0.6)}
STRIP_FRAMES = 6
STRIP_SIZE = 240      # px: each frame is scaled down to this height and width


def write_strip(task: str, out_dir) -> str:
    """A PNG of STRIP_FRAMES frames of one robot-mode attempt of ``task``, spread evenly over the attempt."""
    import pathlib

    import gymnasium as gym
    import imageio.v2 as imageio

    import phyplan_envs

    env = gym.make(phyplan_envs.env_id(task), render_mode="rgb_array_list", robot="panda")
    env.reset(seed=0)
    env.step(np.asarray(STRIP_ACTIONS[task], dtype=np.float64))
    frames = env.render()
    env.close()
    picks = [frames[i] for i in np.linspace(0, len(frames) - 1, STRIP_FRAMES).round().astype(int)]
    step = max(1, picks[0].shape[0] // STRIP_SIZE)
    strip = np.concatenate([f[::step, ::step] for f in picks], axis=1)
    path = pathlib.Path(out_dir) / f"robot_{task}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    imageio.imwrite(str(path), strip)
    return str(path)


def sensitivity(task: str, actions: int, seed: int, deltas) -> dict:
    """The kinematic mode's own sensitivity: the share of ``actions`` random actions (those of the match table) whose
    final position moves by more than 1 cm when every action dimension is moved by ``delta`` (rad or m), per delta:
    a floor under any robot-mode mismatch, since no release is exactly the kinematic one."""
    import gymnasium as gym

    import phyplan_envs
    from benchmarks.design_checks.chaos import landing_moves

    env = gym.make(phyplan_envs.env_id(task)).unwrapped
    moves = landing_moves(env, actions, seed, deltas)
    env.close()
    return {"task": task, "actions": actions, "moved_1cm": {d: float(np.mean(m > 0.01)) for d, m in moves.items()}}


def reach_grid(task: str, n: int) -> dict:
    """Plan (no simulation) every action of an ``n``-per-dimension grid; the unreachable ones and why."""
    import itertools

    import gymnasium as gym

    import phyplan_envs
    from phyplan_envs.panda.robot import RobotFailure

    env = gym.make(phyplan_envs.env_id(task), robot="panda").unwrapped
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    axes = [np.linspace(l, h, n) for l, h in zip(lo, hi)]
    bad = []
    total = 0
    for a in itertools.product(*axes):
        env.reset(seed=0)
        total += 1
        arm = env.executor.arm
        for k, step in enumerate(env.robot_plan(np.array(a))):
            try:       # as RobotArm.execute plans it: the first step from the arm's ready pose
                arm.paths.plan(step, arm.ready_q if k == 0 else None)
            except RobotFailure as e:
                bad.append((tuple(round(float(v), 3) for v in a), str(e).split(" at ")[0]))
                break
    env.close()
    return {"task": task, "grid": n, "total": total, "unreachable": bad}


def main(argv=None) -> None:
    from phyplan_envs import TASKS

    p = argparse.ArgumentParser(description="Robot mode vs kinematic mode: outcome match and cost per task")
    p.add_argument("--tasks", nargs="*", default=list(TASKS), help="task names (default: the four nominal tasks)")
    p.add_argument("--actions", type=int, default=50, help="random actions per task")
    p.add_argument("--seed", type=int, default=0, help="seed of the random actions")
    p.add_argument("--json", default=None, help="also write every attempt's figures to this JSON file")
    p.add_argument("--reach-grid", type=int, default=None, metavar="N",
                   help="instead: plan an N-per-dimension action grid and list the unreachable actions")
    p.add_argument("--breakdown", action="store_true",
                   help="instead: split the CPU time of a robot-mode attempt into its parts, per task")
    p.add_argument("--sensitivity", type=float, nargs="+", default=None, metavar="DELTA",
                   help="instead: the share of the actions whose kinematic outcome moves by more than 1 cm when "
                        "every action dimension moves by DELTA")
    p.add_argument("--strips", default=None, metavar="DIR",
                   help="instead: write a PNG strip of one robot-mode attempt per task to DIR")
    args = p.parse_args(argv)
    if args.strips is not None:
        for t in args.tasks:
            print("wrote", write_strip(t, args.strips))
        return
    if args.actions < 1:
        p.error("--actions must be at least 1")
    if args.reach_grid is not None:
        if args.reach_grid < 2:
            p.error("--reach-grid must be at least 2")
        for t in args.tasks:
            r = reach_grid(t, args.reach_grid)
            print(f"{t}: {r['total'] - len(r['unreachable'])}/{r['total']} grid actions reachable "
                  f"({args.reach_grid} per dimension)")
            for a, why in r["unreachable"]:
                print(f"  unreachable {a}: {why}")
        return
    if args.sensitivity is not None:
        print(f"kinematic mode: share of {args.actions} random actions (seed {args.seed}) whose final position moves "
              "by more than 1 cm when every action dimension moves by delta")
        print("| task | " + " | ".join(f"delta {d:g}" for d in args.sensitivity) + " |")
        print("|---|" + "---|" * len(args.sensitivity))
        for t in args.tasks:
            r = sensitivity(t, args.actions, args.seed, args.sensitivity)
            print(f"| {t} | " + " | ".join(f"{100 * r['moved_1cm'][float(d)]:.0f}%" for d in args.sensitivity) + " |",
                  flush=True)
        return
    if args.breakdown:
        print(f"CPU ms per attempt, {args.actions} random actions per task (seed {args.seed})")
        print("| task | kinematic attempt (flight) | robot attempt | set-up physics (steps) | IK | controller Python | "
              "robot_plan | flight |")
        print("|---|---|---|---|---|---|---|---|")
        for t in args.tasks:
            r = breakdown(t, args.actions, args.seed)
            print(f"| {t} | {r['kin_attempt_ms']:.1f} ({r['kin_flight_ms']:.1f}) | {r['attempt_ms']:.1f} | "
                  f"{r['setup_physics_ms']:.1f} ({r['setup_steps']:.0f}) | {r['ik_ms']:.1f} | {r['python_ms']:.1f} | "
                  f"{r['plan_ms']:.1f} | {r['flight_ms']:.1f} |", flush=True)
        return
    results = [check_task(t, args.actions, args.seed) for t in args.tasks]
    print(f"robot mode vs kinematic mode, {args.actions} random actions per task (seed {args.seed})")
    print("| task | final-position difference median / p90 / max (mm) | within 1 cm | arm carried out | "
          "release error p90 (mm, mm/s) | set-up (sim s) | CPU s/attempt kinematic / robot | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for r in results:
        fails = ", ".join(f"{k} {v}" for k, v in sorted(r["failures"].items())) or "-"
        print(f"| {r['task']} | {r['median_mm']:.2f} / {r['p90_mm']:.2f} / {r['max_mm']:.1f} | "
              f"{100 * r['within_1cm']:.0f}% | {r['robot_ok']}/{r['actions']} ({fails}) | "
              f"{r['hold_error_mm_p90']:.3f}, {r['release_speed_mm_s_p90']:.3f} | {r['setup_time_median']:.1f} | "
              f"{r['seconds_kin']:.4f} / {r['seconds_robot']:.4f} | {r['seconds_robot'] / r['seconds_kin']:.1f}x |")
    print("first robot-mode attempt (untimed above; one-time costs: " + ", ".join(
        f"{r['task']} {r['first_robot_seconds']:.2f} s" for r in results) + ")")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
