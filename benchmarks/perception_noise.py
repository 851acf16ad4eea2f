"""Perception under camera noise: ``phyplan-perception`` with the env's ``camera_noise`` option against without it.

On the hidden-style contexts of :mod:`benchmarks.perception_robust` (``7_310_000 + 7_919 i``, ``i < --contexts``,
outside every split) and for each nominal task, with the ideal camera and with ``camera_noise=--noise`` (default
``"default"``: :mod:`phyplan_envs.camera_noise`), the command reports

1. the pipeline's localisation error (:func:`benchmarks.perception.measure`: the goal's xy error and the object's
   xyz error in mm, against the state of the same context) and the contexts whose goal it cannot read;
2. the regret of ``phyplan-perception`` after 1 and ``--attempts`` attempts, through the harness's cell runner
   (:func:`benchmarks.perception_robust.score`: run seed 0, the env made with the same ``camera_noise``).

    python -m benchmarks.perception_noise --contexts 200 --workers 2 --out results/perception_noise
    python -m benchmarks.perception_noise --contexts 10 --out /tmp/pn10                       # cost check
    python -m benchmarks.perception_noise --noise '{"pose_rotation": 0}' --out /tmp/pn_norot  # one part off

Cells go to ``DIR/cells/*.jsonl`` and are reused by a rerun with the same ``DIR`` (the noisy ones' names end in
the noise's tag); the summary goes to stdout and ``DIR/summary.md``.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shlex
import time

import numpy as np

from benchmarks.perception import measure
from benchmarks.perception_robust import _ci, add_run_arguments, checked_run, score, tasks_flag

AGENT = "phyplan-perception"


def noise_tag(noise) -> str:
    """A short name for the noise setting in cell file names (``""`` for none)."""
    if noise is None:
        return ""
    return "__noise_" + hashlib.sha256(json.dumps(noise, sort_keys=True).encode()).hexdigest()[:10]


def parse_noise(text: str):
    """``--noise``: ``default``, ``none`` or a JSON dict of noise parameters (checked by the env)."""
    from phyplan_envs.camera_noise import check_camera_noise

    value = None if text == "none" else text if text == "default" else json.loads(text)
    check_camera_noise(value, "--noise")
    return value


def localisation(task: str, seeds, noise, image_size: int) -> dict:
    """:func:`benchmarks.perception.measure` with the env's ``camera_noise=noise``."""
    return measure(task, seeds, image_size, env_kwargs={"camera_noise": noise})


def _mm(x) -> str:
    x = 1000 * np.asarray(x, dtype=np.float64)
    return f"{x.mean():.1f} / {np.percentile(x, 90):.1f} / {x.max():.1f}" if len(x) else "- / - / -"


def summarise(loc: dict, regret: dict, tasks, noises: dict, seeds, attempts: int) -> str:
    lines = [f"Hidden-style contexts {seeds[0]} + 7919 i, i < {len(seeds)} (outside every split), 256 x 256 RGB-D; "
             f"`{AGENT}`, {attempts} attempts, run seed 0. Localisation error in mm (mean / p90 / max) over the "
             f"contexts read in full (flagged: an entry unreadable, not scored); regret max(0, 1 - best reward so far), mean ± 95% CI.", "",
             f"| task | camera | goal error (mm) | object error (mm) | flagged | lost | regret@1 | "
             f"regret@{attempts} |", "|---|---|---|---|---|---|---|---|"]
    for task in tasks:
        for label in noises:
            m = loc[(task, label)]
            rows = regret.get((task, label), [])
            by_ctx: dict[int, dict] = {}
            for r in rows:
                by_ctx.setdefault(r["context"], {})[r["attempt"]] = r
            lost = sum(any(r["error"] for r in rr.values()) for rr in by_ctx.values())
            r1 = [rr[1]["regret"] for rr in by_ctx.values()]
            rk = [rr[attempts]["regret"] for rr in by_ctx.values()]
            lines.append(f"| {task} | {label} | {_mm(m['rows']['goal'])} | {_mm(m['rows']['object'])} | "
                         f"{len(m['flagged'])}/{m['n']} | {lost} | {_ci(r1) if r1 else '-'} | "
                         f"{_ci(rk) if rk else '-'} |")
    flagged = [f"* {task}, {label} camera, context {seed}: {why}" for task in tasks for label in noises
               for seed, why in loc[(task, label)]["flagged"]]
    if flagged:
        lines += ["", "Flagged contexts:", ""] + flagged
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(p)
    p.add_argument("--noise", default="default", help="the camera_noise option: 'default' or a JSON dict")
    p.add_argument("--no-regret", action="store_true", help="the localisation errors only (no agent runs)")
    p.add_argument("--out", required=True, help="results directory (resumed if it exists)")
    a = p.parse_args(argv)
    try:
        noise = parse_noise(a.noise)
    except (TypeError, ValueError) as exc:
        p.error(str(exc))
    out, seeds = checked_run(p, a)
    noises = {"ideal": None, "noisy": noise}
    t0 = time.perf_counter()
    loc = {}
    for task in a.tasks:
        for label, n in noises.items():
            loc[(task, label)] = localisation(task, seeds, n, 256)
            print(f"{task} {label}: goal {_mm(loc[(task, label)]['rows']['goal'])} mm, "
                  f"{len(loc[(task, label)]['flagged'])} unreadable", flush=True)
    regret = {}
    if not a.no_regret:
        for label, n in noises.items():
            res = score(out, a.tasks, [AGENT], seeds, a.attempts, a.workers,
                        env_kwargs=None if n is None else {"camera_noise": n}, tag=noise_tag(n))
            regret.update({(task, label): rows for (task, _), rows in res.items()})
    text = summarise(loc, regret, a.tasks, noises, seeds, a.attempts)
    if noise != "default":
        text += f"\n\nNoisy: `camera_noise={json.dumps(noise)}`."
    text += (f"\n\nCommand: `python -m benchmarks.perception_noise --contexts {a.contexts} --workers {a.workers}"
             f"{'' if a.noise == 'default' else f' --noise {shlex.quote(a.noise)}'}"
             f"{'' if a.attempts == 5 else f' --attempts {a.attempts}'}{' --no-regret' if a.no_regret else ''}"
             f"{tasks_flag(a.tasks)} --out {a.out}` "
             f"({time.perf_counter() - t0:.0f} s wall, resumed cells included at no cost)")
    print(text)
    (out / "summary.md").write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
