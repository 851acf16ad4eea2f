"""Memory of repeated env make / reset / step / close cycles: does a process keep what closed envs held?

    python -m benchmarks.memory_cycles --warmup 8 --cycles 150

Cycles over the registered nominal ids (Panda on, default keywords); prints the resident-set growth over the measured
cycles after the warm-up, its peak and the time per cycle. ``--json`` prints one JSON line instead (the test
``tests/test_env_inputs.py`` reads it). Linux only: it reads ``/proc/self/statm``.
"""
from __future__ import annotations

import argparse
import json
import os
import time


def rss_mib() -> float:
    """Resident set size of this process in MiB."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


def measure(warmup: int, cycles: int) -> dict[str, float]:
    import gymnasium as gym

    import phyplan_envs

    ids = [phyplan_envs.env_id(t) for t in phyplan_envs.TASKS]

    def cycle(i: int) -> None:
        env = gym.make(ids[i % len(ids)])
        env.reset(seed=i)
        env.step(env.action_space.sample())
        env.close()

    start = rss_mib()
    for i in range(warmup):
        cycle(i)
    r0 = peak = rss_mib()
    t0 = time.perf_counter()
    for i in range(cycles):
        cycle(i)
        peak = max(peak, rss_mib())
    seconds = (time.perf_counter() - t0) / max(cycles, 1)
    return {"start_mib": start, "after_warmup_mib": r0, "growth": rss_mib() - r0, "peak": peak - r0,
            "ms_per_cycle": 1000 * seconds}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--warmup", type=int, default=8, help="cycles before the measurement (fill caches)")
    ap.add_argument("--cycles", type=int, default=50, help="measured cycles")
    ap.add_argument("--json", action="store_true", help="print one JSON line")
    args = ap.parse_args(argv)
    if args.warmup < 0 or args.cycles < 1:
        ap.error("--warmup must be >= 0 and --cycles >= 1")
    out = measure(args.warmup, args.cycles)
    if args.json:
        print(json.dumps(out))
    else:
        print(f"start {out['start_mib']:.0f} MiB, after {args.warmup} warm-up cycles {out['after_warmup_mib']:.0f} MiB; "
              f"{args.cycles} more cycles: {out['growth']:+.1f} MiB (peak {out['peak']:+.1f}), "
              f"{out['ms_per_cycle']:.0f} ms per cycle")


if __name__ == "__main__":
    main()
