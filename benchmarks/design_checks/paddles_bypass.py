"""Paddles-N's bypasses: where a ball lands that skips some paddle, against where chains that meet every paddle land,
and so which goals only a whole chain reaches (docs/depth.md, *Bypasses*).

Every Paddles context shares one scene (paddle 0 fixed, the same release-angle range); only the goal differs. So
where the ball can land, for each set of paddles it meets, is a fact of N alone. A *partial action* is drawn paddle
by paddle as :func:`benchmarks.design_checks.paddles.chain_action` draws a chain action, except that each placed
paddle is, with probability 1/2, put at a grid point where the ball (with the paddles before it as drawn) misses
its face instead of one where it meets it; the drawn action counts if its ball does not touch at least one paddle
anywhere (face, edge or corner: ``met_paddles(..., board=True)``), and is keyed by the paddles it touches.

A goal at x (on y = 0, ahead of the ball's start) is *bypass-proof* when no sampled partial action lands within
``0.1 |x|`` of it: no action that skips a paddle scores 0.9 there. The command prints, per N, the landing ranges
of each set of paddles touched, and the bypass-proof stretches of x within the chain actions' landings::

    python -m benchmarks.design_checks.paddles_bypass --actions 120 --depths 3 4 5 6

``--version 0`` studies Paddles-v0 (the paddles' absolute x) instead of v2 (each paddle's offset from the one above).
``--relative K`` (a study of v0, the one that led to v1) draws K actions as a placement relative to the paddle
above would: the release angle uniform and each placed paddle's offset from the paddle above, along the way the ball
leaves it, uniform in ``--offsets LO HI`` (the chain offsets that ``python -m benchmarks.design_checks.paddles
--reach --version 0`` prints); it counts those whose paddles fall inside v0's [-1, 1] m and, of those, the ones whose
ball touches every paddle::

    python -m benchmarks.design_checks.paddles_bypass --relative 200 --offsets 0.45 0.9 --depths 2 3 4 5 6

The stretches are estimates from a sample (a partial action not drawn could land inside one); the solver of
``python -m benchmarks.design_checks.paddles --solvable`` reports, per context, whether its solution touches every
paddle.
"""
from __future__ import annotations

import argparse
import collections
import time

import numpy as np

from benchmarks.design_checks.paddles import TEST_SEED
from benchmarks.design_checks.paddles_actions import VERSION, attempt, chain_actions, make, paddle_by_paddle

MATTERS_SHARE = 0.1      # a landing within this share of the goal's distance scores at least 0.9
STEP = 0.01              # m: the x grid on which bypass-proof stretches are found


def partial_draw(env, context, rng) -> np.ndarray | None:
    """An action drawn as a partial action is (module docstring; it counts only if its ball skips a paddle), or None
    when a drawn choice has no grid point."""
    def choose(i, met):
        meet = rng.random() < 0.5
        return [m[i] == meet for m in met]

    return paddle_by_paddle(env, context, rng, choose)


def landings(n: int, k: int, seed: int, version: int = VERSION) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Up to ``k`` partial actions' and ``k`` chain actions' landing x on the context of ``reset(seed=seed)`` of
    Paddles-v<version>: (the partial landings keyed by the paddles touched, e.g. ``"1101"``; the chain landings)."""
    env = make(n, version=version, record_trajectory=True)
    env.reset(seed=seed)
    context = env.context
    rng = np.random.default_rng(seed)
    part = collections.defaultdict(list)
    for _ in range(k):
        a = partial_draw(env, context, rng)
        if a is not None:
            _, x, touched = attempt(env, context, a, board=True)
            if not all(touched):
                part["".join("1" if t else "0" for t in touched)].append(x)
    full = np.array([attempt(env, context, a)[1] for a in chain_actions(env, context, k, rng)])
    return {key: np.array(v) for key, v in sorted(part.items())}, full


def bypass_proof(partial: np.ndarray, lo: float, hi: float, nearest: float) -> list[tuple[float, float]]:
    """The stretches of x in [max(lo, nearest), hi] (on a ``STEP`` grid) with no landing of ``partial`` within
    ``MATTERS_SHARE |x|``."""
    xs = np.arange(max(lo, nearest), hi + STEP / 2, STEP)
    if len(partial):
        ok = np.abs(xs[:, None] - partial[None, :]).min(axis=1) > MATTERS_SHARE * np.abs(xs)
    else:
        ok = np.ones(len(xs), dtype=bool)
    out, start = [], None
    for x, good in zip(xs, ok):
        if good and start is None:
            start = x
        if not good and start is not None:
            out.append((start, x - STEP))
            start = None
    if start is not None:
        out.append((start, xs[-1]))
    return [(float(a), float(b)) for a, b in out]


def relative_share(n: int, k: int, seed: int, offsets: tuple[float, float]) -> tuple[int, int]:
    """``k`` relative draws (module docstring) on the context of ``reset(seed=seed)`` of Paddles-v0: (how many fit in
    its action bounds, how many of those touch every paddle)."""
    env = make(n, version=0, record_trajectory=True)
    env.reset(seed=seed)
    context = env.context
    rng = np.random.default_rng(seed)
    lo, hi = env.action_low, env.action_high
    falls = np.array(env.facts.paddle_falls[:-1], dtype=np.float64)
    fit = chained = 0
    for _ in range(k):
        a = np.empty(n)
        a[0] = rng.uniform(lo[0], hi[0])
        a[1:] = env.facts.first_paddle_x + np.cumsum(falls * rng.uniform(*offsets, size=n - 1))
        if np.all(lo <= a) and np.all(a <= hi):
            fit += 1
            chained += all(attempt(env, context, a, board=True)[2])
    return fit, chained


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.design_checks.paddles_bypass", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--depths", type=int, nargs="+", default=[2, 3, 4, 5, 6], help="the N to check (>= 2)")
    p.add_argument("--actions", type=int, default=120,
                   help="partial and chain actions drawn per N (default 120)")
    p.add_argument("--nearest", type=float, default=0.1,
                   help="the nearest goal x considered (m; the reward divides by the goal's distance)")
    p.add_argument("--relative", type=int, default=0, metavar="K",
                   help="K relative draws per N instead of the bypass study (module docstring)")
    p.add_argument("--offsets", type=float, nargs=2, default=(0.45, 0.9), metavar=("LO", "HI"),
                   help="with --relative: the offsets' range (m; default 0.45 0.9)")
    p.add_argument("--version", type=int, choices=(0, 1, 2), default=VERSION,
                   help="the Paddles version of the bypass study (default 2; --relative studies v0)")
    p.add_argument("--seed", type=int, default=TEST_SEED)
    args = p.parse_args(argv)
    if args.relative < 0 or not (0 <= args.offsets[0] <= args.offsets[1] <= 2):
        p.error(f"--relative must be >= 0 and --offsets 0 <= LO <= HI <= 2 m, got {args.relative}, {args.offsets}")
    if any(n < 2 for n in args.depths):
        p.error(f"--depths must be >= 2 (N = 1 has no paddle to skip), got {args.depths}")
    if args.actions < 1:
        p.error(f"--actions must be >= 1, got {args.actions}")
    if not args.nearest > 0:
        p.error(f"--nearest must be > 0 m, got {args.nearest}")
    for n in args.depths:
        t0 = time.perf_counter()
        if args.relative:
            fit, chained = relative_share(n, args.relative, args.seed, tuple(args.offsets))
            print(f"N={n}: {args.relative} relative draws (offsets {args.offsets[0]:g}-{args.offsets[1]:g} m): "
                  f"{fit} in bounds, of which {chained} ({100 * chained / max(fit, 1):.0f}%) touch every paddle "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
            continue
        part, full = landings(n, args.actions, args.seed, args.version)
        print(f"N={n}: {sum(map(len, part.values()))} partial actions, {len(full)} chain actions "
              f"({time.perf_counter() - t0:.0f} s)")
        for key, x in [*part.items(), ("1" * n + " (chain)", full)]:
            q = np.percentile(x, [0, 5, 50, 95, 100])
            print(f"  touched {key}: {len(x):4d}; landing x min {q[0]:.3f}, p5 {q[1]:.3f}, p50 {q[2]:.3f}, "
                  f"p95 {q[3]:.3f}, max {q[4]:.3f} m")
        if len(full):
            lo, hi = np.percentile(full, [5, 95])
            allpart = np.concatenate(list(part.values())) if part else np.empty(0)
            proof = bypass_proof(allpart, lo, hi, args.nearest)
            inside = np.mean([any(a <= x <= b for a, b in proof) for x in full])
            print(f"  bypass-proof goals within the chain landings' p5-p95 ({lo:.3f}-{hi:.3f} m): "
                  + (", ".join(f"{a:.2f}-{b:.2f}" for a, b in proof) or "none")
                  + f" m ({100 * inside:.0f}% of chain landings fall there)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
