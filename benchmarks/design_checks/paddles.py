"""Paddles-N's design checks, per N: where chains that meet every paddle land (the goal ranges), whether every
context is solvable and every paddle matters, and whether the landing converges in the timestep and is not chaotic.
They check Paddles-v2 (each placed paddle's offset from the one above); ``--version 0`` checks Paddles-v0 (the
paddles' absolute x), whose figures in docs/depth.md come from the commands below with ``--version 0``, and
``--version 1`` Paddles-v1 (v2 with a 4 s episode cap at every N; the same outcomes up to N = 6).

A *chain action* meets every paddle. They are drawn paddle by paddle (:mod:`.paddles_actions`): the release angle
uniform, then each placed paddle's action value (v1: its offset; v0: its x) uniform among the points of a 0.05 m
grid over its bounds where the ball, with the paddles before it as drawn, meets it (read from
``info["trajectory"]``: the centre within 4 mm of the face's contact distance inside the face, at the samples; on a
bouncing design also between them), jittered by U(-0.025, 0.025) m; a draw where no grid point works is dropped.

``--reach K``: K chain actions per N: the landings' percentiles (the goal ranges of
:data:`phyplan_envs.tasks.paddles.GOAL_RANGE` are their p5-p95)::

    python -m benchmarks.design_checks.paddles --reach 100 --depths 2 3 4 5 6

``--restitution E ...`` (with ``--reach``): the same on PaddlesVaried-v3 at each hidden restitution E (the bands its
goals are drawn in, :data:`phyplan_envs.hidden_physics.tasks.PADDLES_REACH`)::

    python -m benchmarks.design_checks.paddles --reach 40 --aimed --depths 1 2 3 4 5 6 \
        --restitution 0.02 0.05 0.1 0.15 0.2 0.25 0.3 0.35 0.4

``--solvable C``: on C test contexts per N, the certificate solver (:func:`solve`: a chain action, then a
coordinate search from it, up to ``--starts`` times, default 3) reaches reward >= 0.95; and every paddle matters:
moving any one placed paddle by +-0.2 m from the solution drops the reward below 0.9. It also says on how many
contexts the solution's ball touches every paddle's board (face, edge or corner); ``--chain-only`` keeps the solver
to actions whose ball meets every paddle's face::

    python -m benchmarks.design_checks.paddles --solvable 50 --depths 1 2 3 4 5 6
    python -m benchmarks.design_checks.paddles --solvable 20 --depths 3 --chain-only

``--shift S`` (with ``--solvable``) moves each paddle by S m instead of 0.2 m in the "every paddle matters" check
(a study's far goals need a larger move)::

    python -m benchmarks.design_checks.paddles --solvable 5 --depths 2 --shift 0.5 --goal-range 2.046 2.247 \
        --aimed --paddle-restitution 0.8 --offset-span 0.5 5.0 --timestep 1.5625e-5 --max-sim-time 10

``--move-alone`` (with ``--solvable``; v1/v2) moves each paddle alone in that check: its x by +-S while every other
paddle stays where it is, so its offset and the next paddle's change together, and both must stay in their bounds
(the default moves its action value, its offset, and so every paddle below it along). It also prints on how many
contexts neither side fitted, and the range of the best rewards after the moves that did::

    python -m benchmarks.design_checks.paddles --solvable 5 --depths 3 --move-alone --goal-range 2.453 2.759 \
        --aimed --paddle-restitution 0.8 --offset-span 0.5 5.0 --timestep 1.5625e-5 --max-sim-time 10

``--relative`` (with ``--chain-only --version 0``) studies, on v0, placing each paddle relative to the one above (the
study that led to v1): its check moves a paddle's offset, so the paddle and every paddle below it move together::

    python -m benchmarks.design_checks.paddles --solvable 20 --depths 3 4 5 6 --chain-only --relative --version 0

``--goal-range LO HI`` (with ``--solvable``): each context's goal at x = U(LO, HI) m instead of the task's
sampler, to study which goals make every paddle matter (docs/depth.md)::

    python -m benchmarks.design_checks.paddles --solvable 20 --depths 3 --goal-range 0.810 0.909 --version 0

``--chaos K``: K chain actions per N: how far the landing moves when every action dimension moves by each of
``--deltas`` and when the timestep halves::

    python -m benchmarks.design_checks.paddles --chaos 200 --depths 1 2 3 4 5 6

Each share of moved landings comes with its 95% Clopper-Pearson interval. ``--halvings H`` measures the same on the
task with its timestep halved H times, to tell chaos that a finer timestep removes from the physics' own (a ball
that grazes a paddle's edge)::

    python -m benchmarks.design_checks.paddles --chaos 200 --depths 4 --halvings 1

``--per-context`` (with ``--chaos``) draws one chain action on each of K contexts, ``--seed + --seed-step * i``,
as LaunchBounce's check (``benchmarks.design_checks.launch_bounce --chaos``) does, instead of K on one. On Paddles
a context is only its goal, which moves no landing, so this gives the one-context figures (the actions are the
same draws of ``default_rng(--seed)``); on PaddlesVaried each context brings its own restitution::

    python -m benchmarks.design_checks.paddles --chaos 100 --depths 2 --per-context --physics-space test

``--physics-space SPACE`` (with ``--chaos``) measures the same on the hidden-physics version (PaddlesVaried-v3 on
Paddles-v2, v1 on v1, v0 on v0; ``--varied-version 2``: the superseded v2), its restitution from SPACE (``train`` or
``test``), drawn per context::

    python -m benchmarks.design_checks.paddles --chaos 20 --depths 1 2 3 4 5 6 --physics-space train
    python -m benchmarks.design_checks.paddles --chaos 30 --depths 1 2 3 --physics-space train --varied-version 2

``--paddle-size EDGE`` and ``--paddle-tilt DEG`` run any of these with square paddles of that edge (m) or tilt
(degrees from horizontal) in place of the task's 0.5 m and 45 degrees, studies of whether other paddles make every
paddle matter; the goals stay the task's unless ``--goal-range`` places them::

    python -m benchmarks.design_checks.paddles --reach 40 --depths 3 --paddle-size 0.3 --version 0
    python -m benchmarks.design_checks.paddles --reach 40 --depths 3 --paddle-tilt 30 --version 0

``--paddle-restitution E``, ``--timestep DT`` and ``--offset-span LO HI`` run them on a study of bouncing paddles:
a soft ball-paddle contact of restitution E (the task's keeps none of the normal speed), at timestep DT, with v1's
offsets in [LO, HI] m. Its face test also looks between the flight's samples, where a bounce's touch falls
(``--face-at-samples``: at the samples alone, as the task's; ``--face-test``). Which restitutions a hidden-physics
Paddles can vary and still converge and not be chaotic (docs/depth.md, *Hidden physics*); ``--episode-cost K``
times K random actions' episodes on it and on the task::

    python -m benchmarks.design_checks.paddles --chaos 20 --depths 1 2 3 --paddle-restitution 0.8 \
        --offset-span 0.5 3.0 --timestep 1.5625e-5 --deltas 1e-6 1e-4
    python -m benchmarks.design_checks.paddles --episode-cost 5 --depths 2 3 --paddle-restitution 0.8 \
        --offset-span 0.5 3.0 --timestep 1.5625e-5

``--aimed`` draws every check's chain actions aimed instead (:func:`.paddles_actions.aimed_action`: each placed
paddle put where the ball's flight, with the paddles above as drawn, meets its face at a point uniform along it; one
episode per paddle where the grid takes one per grid point: on the task 3-8 times faster, on a study's offsets of
0.5-5 m (91 grid points) tens of times). Its landings spread like the grid's, not identically: it aims away from
the faces' edges (on the task at N = 2..6, 40 actions each, the medians within 0.14 m of the grid's, p5 and p95
within 0.27 m)::

    python -m benchmarks.design_checks.paddles --reach 40 --depths 2 3 4 5 6 --aimed
    python -m benchmarks.design_checks.paddles --reach 40 --depths 2 3 4 5 6

``--chain K``: K chain actions per N of one dev context: how far the composed chain's landing, with the project's
skills unchanged, is from the simulator's (as ``python -m benchmarks.depth --section accuracy``, on the checked
design: whether the same skills compose on a study's paddles), and how fast the simulator's ball meets each paddle
(a skill predicts only inside its data's speeds)::

    python -m benchmarks.design_checks.paddles --chain 20 --depths 1 2 3 --paddle-restitution 0.8 \
        --offset-span 0.5 3.0 --timestep 1.5625e-5

``--face-test K``: on K uniform random actions per N, how many balls meet each paddle's face by the test at the
samples (the task's) and by the test on the free flights between them too (a bouncing design's), and on how many
actions the two disagree (:func:`.paddles_actions.met_paddles`)::

    python -m benchmarks.design_checks.paddles --face-test 400 --depths 1 2 3 4

Where balls that skip a paddle land: :mod:`benchmarks.design_checks.paddles_bypass`.

Figures: docs/depth.md.
"""
from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace

import numpy as np

from benchmarks.design_checks.paddles_actions import EDGE, TILT, VERSION, Design, episode_cost, episode_ends, face_tests
from benchmarks.design_checks.paddles_landings import chaos, reach, share_interval
from benchmarks.design_checks.paddles_solver import MATTERS, SHIFT, SOLVED, solvable
from phyplan_envs.tasks.paddles import TIMESTEP as TASK_TIMESTEP

TEST_SEED, TEST_STEP = 7310000, 7919


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.design_checks.paddles", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--depths", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6], help="the N to check")
    p.add_argument("--reach", type=int, default=0, metavar="K", help="K chain actions per N: landing percentiles")
    p.add_argument("--solvable", type=int, default=0, metavar="C", help="C test contexts per N: the solver")
    p.add_argument("--shift", type=float, default=SHIFT, metavar="S",
                   help=f"with --solvable: the move of the 'every paddle matters' check (m; default {SHIFT})")
    p.add_argument("--starts", type=int, default=3, help="the solver's chain-action starts per context (default 3)")
    p.add_argument("--goal-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="with --solvable: put each context's goal at x = U(LO, HI) m, y = 0, in place of the "
                        "task's sampler (a study of other goal ranges)")
    p.add_argument("--paddle-size", type=float, default=EDGE, metavar="EDGE",
                   help="the paddles' edge in m (default 0.5, the task's): a study of other sizes; the goals stay the "
                        "task's, so give --goal-range from a --reach at that size")
    p.add_argument("--paddle-tilt", type=float, default=TILT, metavar="DEG",
                   help="the paddles' tilt from horizontal in degrees (default 45, the task's): a study of other "
                        "tilts; give --goal-range from a --reach at that tilt")
    p.add_argument("--paddle-restitution", type=float, default=0.0, metavar="E",
                   help="the ball-paddle restitution in [0, 1) (default 0, the task's: the paddles keep none of the "
                        "normal speed): a study of bouncing paddles (a soft contact of that restitution)")
    p.add_argument("--timestep", type=float, default=None, metavar="DT",
                   help="a study's timestep in s, in [5e-6, 5e-4] (default the task's, 0.0005); --halvings halves it")
    p.add_argument("--offset-span", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="a study's bounds of v1's paddle offsets in m, 0.1 <= LO < HI <= 6 (default the task's "
                        "0.45-0.9; bouncing balls fly farther)")
    p.add_argument("--episode-cost", type=int, default=0, metavar="K",
                   help="K random actions per N: CPU time per episode (least of 3) of the checked design and of the "
                        "task (a study's cost)")
    p.add_argument("--chain", type=int, default=0, metavar="K",
                   help="K chain actions per N: the composed chain's landing error against the simulator's")
    p.add_argument("--max-sim-time", type=float, default=None, metavar="S",
                   help="a study's episode cap in s (default the task's 4 s)")
    p.add_argument("--episode-end", type=int, default=0, metavar="K",
                   help="K random actions per N: how their episodes end (landed, rest, timeout) and how long they take")
    p.add_argument("--face-at-samples", action="store_true",
                   help="a bouncing design's face test at the flight's samples alone, as the task's")
    p.add_argument("--face-test", type=int, default=0, metavar="K",
                   help="K random actions per N: the face test at the samples against the one between them too")
    p.add_argument("--aimed", action="store_true",
                   help="draw the chain actions aimed (one episode per placed paddle: where the ball's flight meets "
                        "each face) instead of on the 0.05 m grid (one episode per grid point)")
    p.add_argument("--chain-only", action="store_true",
                   help="with --solvable: the solver keeps only actions whose ball meets every paddle")
    p.add_argument("--relative", action="store_true",
                   help="with --chain-only: move each paddle's offset from the paddle above (it and every paddle "
                        "below) in the every-paddle-matters check, a study of relative placement")
    p.add_argument("--move-alone", action="store_true",
                   help="with --solvable, on --version 1 or 2: move each paddle alone (its x by +-S, every other "
                        "paddle where it is) in the every-paddle-matters check, instead of its offset (it and every "
                        "paddle below)")
    p.add_argument("--chaos", type=int, default=0, metavar="K", help="K chain actions per N: chaos, convergence")
    p.add_argument("--deltas", type=float, nargs="+", default=[1e-8, 1e-6, 1e-4])
    p.add_argument("--halvings", type=int, default=0,
                   help="with --chaos: measure on the task with its timestep halved this many times (default 0: the "
                        "task's 0.5 ms), to tell numerical chaos from physical")
    p.add_argument("--version", type=int, choices=(0, 1, 2), default=VERSION,
                   help="the Paddles version (default 2: each placed paddle's offset from the one above; 1: the "
                        "same with a 4 s episode cap at every N; 0: the paddles' absolute x)")
    p.add_argument("--per-context", action="store_true",
                   help="with --chaos: one chain action on each of K contexts (--seed + --seed-step * i), as "
                        "LaunchBounce's check, instead of K on one context")
    p.add_argument("--physics-space", choices=("train", "test"), default=None,
                   help="with --chaos or --episode-end: check PaddlesVaried, its restitution from this physics space")
    p.add_argument("--restitution", type=float, nargs="+", default=None, metavar="E",
                   help="with --reach: on PaddlesVaried with each of these hidden restitutions (the goal bands of v3)")
    p.add_argument("--varied-version", type=int, choices=(0, 1, 2, 3), default=None,
                   help="with --physics-space: the PaddlesVaried version (default: v3 on --version 2, else v0 or v1; "
                        "v2 is the superseded soft impact pair on Paddles-v2)")
    p.add_argument("--seed", type=int, default=TEST_SEED, help="first context seed (default the test split's)")
    p.add_argument("--seed-step", type=int, default=TEST_STEP)
    args = p.parse_args(argv)
    checks = ("reach", "solvable", "chaos", "episode_cost", "chain", "face_test", "episode_end")
    if not any(getattr(args, name) for name in checks):
        p.error("give at least one of --reach, --solvable, --chaos, --episode-cost, --chain, --face-test, "
                "--episode-end")
    for name in checks:
        if getattr(args, name) < 0:
            p.error(f"--{name.replace('_', '-')} must be >= 0, got {getattr(args, name)}")
    if any(n < 1 for n in args.depths):
        p.error(f"--depths must be >= 1, got {args.depths}")
    if not 0.0 < args.shift <= 2.0 or (args.shift != SHIFT and not args.solvable):
        p.error(f"--shift must be in (0, 2] m and needs --solvable, got {args.shift}")
    if args.starts < 1:
        p.error(f"--starts must be >= 1, got {args.starts}")
    if not 0.05 <= args.paddle_size <= 1.0:
        p.error(f"--paddle-size must be in [0.05, 1.0] m, got {args.paddle_size}")
    if not 5.0 <= args.paddle_tilt <= 80.0:
        p.error(f"--paddle-tilt must be in [5, 80] degrees, got {args.paddle_tilt}")
    if args.chain_only and not args.solvable:
        p.error("--chain-only needs --solvable")
    if args.relative and not (args.chain_only and args.version == 0):
        p.error("--relative needs --chain-only and --version 0 (a study of v0; v1 places the paddles relatively)")
    if args.move_alone and not (args.solvable and args.version >= 1 and not args.relative):
        p.error("--move-alone needs --solvable and --version 1 or 2, and not --relative (on v0 an action value is a "
                "paddle's x, which already moves alone)")
    if args.halvings < 0 or (args.halvings and not args.chaos):
        p.error(f"--halvings must be >= 0 and needs --chaos, got {args.halvings}")
    if args.per_context and not args.chaos:
        p.error("--per-context needs --chaos")
    if args.max_sim_time is not None and not 1.0 <= args.max_sim_time <= 30.0:
        p.error(f"--max-sim-time must be in [1, 30] s, got {args.max_sim_time}")
    if args.face_at_samples and not args.paddle_restitution:
        p.error("--face-at-samples needs --paddle-restitution > 0 (the task's face test is at the samples)")
    if not 0.0 <= args.paddle_restitution < 1.0:
        p.error(f"--paddle-restitution must be in [0, 1), got {args.paddle_restitution}")
    if args.timestep is not None and not 5e-6 <= args.timestep <= 5e-4:
        p.error(f"--timestep must be in [5e-6, 5e-4] s, got {args.timestep}")
    if args.offset_span is not None and not (0.1 <= args.offset_span[0] < args.offset_span[1] <= 6.0
                                             and args.version >= 1):
        p.error(f"--offset-span needs --version 1 or 2 and 0.1 <= LO < HI <= 6 m, got {args.offset_span}")
    design = Design(args.paddle_size, args.paddle_tilt, args.version, args.paddle_restitution, args.timestep,
                    None if args.offset_span is None else tuple(args.offset_span), args.max_sim_time,
                    args.face_at_samples)
    if args.restitution is not None and not (args.reach and design.is_task() and args.version == 2
                                             and all(0.0 <= e <= 1.0 for e in args.restitution)):
        p.error(f"--restitution needs --reach, the task's paddles on --version 2 and values in [0, 1], got "
                f"{args.restitution}")
    if args.varied_version is not None:
        if not args.physics_space or (args.varied_version >= 2) != (args.version == 2) or (
                args.varied_version < 2 and args.varied_version != args.version):
            p.error("--varied-version needs --physics-space and its own Paddles --version (v0: 0, v1: 1, v2 and v3: 2)")
        design = replace(design, varied_version=args.varied_version)
    if args.physics_space and not ((args.chaos or args.episode_end) and design.is_task()):
        p.error("--physics-space needs --chaos or --episode-end and the task's paddles (no --paddle-size, "
                "--paddle-tilt, --paddle-restitution, --timestep or --offset-span)")
    if args.goal_range is not None and not (args.solvable and args.goal_range[0] <= args.goal_range[1]
                                            and all(map(math.isfinite, args.goal_range))):
        p.error(f"--goal-range needs --solvable and finite LO <= HI, got {args.goal_range}")
    for n in args.depths:
        t0 = time.perf_counter()
        for e in (args.restitution or [None]) if args.reach else ():
            x, offsets, airborne = reach(n, args.reach, args.seed, design, args.aimed, e)
            q = np.percentile(x, [0, 5, 50, 95, 100]) if len(x) else [math.nan] * 5
            at = "" if e is None else f" at restitution {e:g}"
            print(f"N={n} reach{at}: {len(x)} chain actions; landing x min {q[0]:.3f}, p5 {q[1]:.3f}, p50 {q[2]:.3f}, "
                  f"p95 {q[3]:.3f}, max {q[4]:.3f} m" + (f" (NOT LANDED: {airborne} episodes ended with the ball in "
                                                         "the air; --max-sim-time)" if airborne else "")
                  + f" ({time.perf_counter() - t0:.0f} s)", flush=True)
            if len(x) and n > 1:
                print(f"N={n} chain offsets (each placed paddle from the one above, along the ball's way), p5-p95: "
                      + ", ".join("{:.2f}-{:.2f}".format(*np.percentile(o, [5, 95])) for o in offsets.T) + " m")
        if args.solvable:
            s = solvable(n, args.solvable, args.seed, args.seed_step, args.starts, args.goal_range,
                         design, args.chain_only, args.relative, args.aimed, args.shift, args.move_alone)
            ok = s["rewards"] >= SOLVED
            m = s["matters"]
            move = f"{'each paddle moved alone, ' if args.move_alone else ''}+-{args.shift:g} m < {MATTERS}"
            print(f"N={n} solvable: {ok.sum()}/{len(ok)} contexts at reward >= {SOLVED} ({100 * ok.mean():.0f}%); "
                  f"median best {np.median(s['rewards']):.3f}, min {s['rewards'].min():.3f}; median attempts "
                  f"{np.median(s['calls']):.0f}" + (f"; every paddle matters ({move}) on "
                                                    f"{m.sum()}/{len(m)} solved contexts (per placed paddle 1.."
                                                    f"{n - 1}: {', '.join(map(str, s['per_paddle'].sum(0)))}); "
                                                    f"the solution's ball touches every paddle on "
                                                    f"{s['chained'].sum()}/{len(m)}, and every paddle matters on "
                                                    f"{(m & s['chained']).sum()} of those"
                                                    if n > 1 else "")
                  + (f"; no alone move fitted the bounds (per placed paddle 1..{n - 1}): "
                     f"{', '.join(map(str, s['unfit'].sum(0)))}; the best reward after it where one fitted: "
                     + ", ".join(f"{np.nanmin(v):.3f} to {np.nanmax(v):.3f}" if np.any(~np.isnan(v)) else "none"
                                 for v in s["moved"].T) if args.move_alone and n > 1 else "")
                  + f" ({time.perf_counter() - t0:.0f} s)", flush=True)
        if args.episode_cost:
            mine, task = episode_cost(n, args.episode_cost, args.seed, design)
            print(f"N={n} episode cost over {args.episode_cost} random actions: {1000 * mine:.1f} ms CPU, the task "
                  f"{1000 * task:.1f} ms ({mine / task:.1f}x)", flush=True)
        if args.episode_end:
            e = episode_ends(n, args.episode_end, args.seed, design, args.physics_space)
            print(f"N={n} episode ends over {args.episode_end} random actions: "
                  + ", ".join(f"{k} {v}" for k, v in sorted(e["reasons"].items()))
                  + f"; simulated time median {np.median(e['sim_time']):.2f} s, max {e['sim_time'].max():.2f} s "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
        if args.face_test:
            f = face_tests(n, args.face_test, args.seed, design)
            print(f"N={n} face test over {args.face_test} random actions: paddles met at the samples "
                  f"{f['samples'].tolist()}, between them too {f['between'].tolist()}; the tests differ on "
                  f"{f['differ']} actions ({time.perf_counter() - t0:.0f} s)", flush=True)
        if args.chain:
            from benchmarks.depth import accuracy

            a = accuracy(n, args.chain, seed=n, design=design, aimed=args.aimed)
            if not a["actions"]:
                print(f"N={n} chain: no chain action in {5 * args.chain} draws", flush=True)
            else:
                print(f"N={n} chain over {a['actions']} chain actions: landing error mean {100 * a['mean_m']:.1f} "
                      f"cm, p90 {100 * a['p90_m']:.1f} cm, no prediction for {100 * a['no_prediction']:.0f}%; "
                      "the ball's speed meeting each paddle, median (max): "
                      + ", ".join(f"{np.nanmedian(v):.1f} ({np.nanmax(v):.1f})" for v in a["arrival"].T)
                      + f" m/s ({time.perf_counter() - t0:.0f} s)", flush=True)
        if args.chaos:
            c = chaos(n, args.chaos, args.seed, args.deltas, args.halvings, design, args.physics_space,
                      args.seed_step if args.per_context else None, args.aimed)
            if not c["actions"]:
                print(f"N={n} chaos: no chain action in {5 * args.chaos} draws", flush=True)
                continue
            parts = [f"delta {d:g}: {100 * np.mean(v > 0.01):.1f}% move > 1 cm (95% interval "
                     + "{:.1f}-{:.1f}%)".format(*(100 * x for x in share_interval(int(np.sum(v > 0.01)), len(v))))
                     + (f" (max {100 * v.max():.1f} cm; {int(np.sum(c['other_paddles'][d] & (v > 0.01)))} of them "
                        "met another set of paddles)" if np.any(v > 0.01) else "")
                     for d, v in c["moves"].items()]
            step = 1000 * (args.timestep or TASK_TIMESTEP) / 2 ** args.halvings
            where = f" on {c['contexts']} contexts" if args.per_context else ""
            where += (f" (restitution {'median ' if args.per_context else ''}{c['restitution']:.3f})"
                      if "restitution" in c else "")
            print(f"N={n} chaos over {c['actions']} chain actions{where} at timestep {step:g} ms: " + "; ".join(parts)
                  + f"; timestep halved: p90 {1000 * np.percentile(c['halved'], 90):.2f} mm, max "
                  f"{1000 * c['halved'].max():.2f} mm ({time.perf_counter() - t0:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
