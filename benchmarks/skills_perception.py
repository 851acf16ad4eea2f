"""Skill data read from camera frames for the skills study (``python -m benchmarks.skills --perception``).

The data come from :mod:`phyplan_agents.perception.skill_data` (the same initial conditions and query times as the
simulator's data, row for row) and are cached per skill and seed in the study's ``--out``; :func:`reading_error`
is the summary's table of their error against the simulator's values of the same rows.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

PERCEPTION_SIZES = (25, 50, 100, 200)
PERCEPTION_SKILLS = ("swing", "slide", "throw")
# per skill: (input, true extra, unit scale, unit) of the columns whose reading error the summary reports
_READ_COLUMNS = {
    "slide": (("v_init", "in", 0, "true_v_init", "mm/s"), ("x", "out", 0, "true_x", "mm"),
              ("v", "out", 1, "true_v", "mm/s")),
    "swing": (("theta_init", "in", 0, "true_theta_init", "mrad"), ("theta", "out", 0, "true_theta", "mrad"),
              ("omega", "out", 1, "true_omega", "mrad/s")),
    "throw": (("v_hor", "in", 0, "true_v_hor", "mm/s"), ("v_ver (release)", "in", 1, "true_v_ver", "mm/s"),
              ("x", "out", 0, "true_x", "mm"), ("y", "out", 1, "true_y", "mm"),
              ("v_ver (at t)", "out", 2, "true_v_ver_t", "mm/s")),
}


def perception_data(out: Path, skill: str, seed: int, n: int):
    """The first ``n`` samples of ``skill`` and ``seed`` read from camera frames, cached in ``out``."""
    from phyplan_agents.perception import skill_data
    from phyplan_envs.skill_scenes import SkillData

    path = out / f"perception_{skill}_seed{seed}.npz"
    if path.is_file():
        z = np.load(path)
        if len(z["inputs"]) >= n:
            extras = {k[6:]: z[k][:n] for k in z.files if k.startswith("extra_")}
            return SkillData(skill, z["inputs"][:n], z["outputs"][:n], seed, extras)
    t0 = time.perf_counter()
    data = getattr(skill_data, f"{skill}_data")(n, seed, progress=True)
    print(f"perception data, {skill} seed {seed}: {n} samples read from frames in {time.perf_counter() - t0:.0f} s",
          flush=True)
    np.savez(path, inputs=data.inputs, outputs=data.outputs, **{f"extra_{k}": v for k, v in data.extras.items()})
    return data


def reading_error(given: dict, n: int) -> str:
    """The perception data's error against the simulator's values of the same rows (markdown)."""
    lines = ["# Skill data read from camera frames", "",
             f"Reading error (RMSE; max in brackets) of the first {n} samples per seed against the simulator's "
             "values of the same rows (the query times are the simulator data's: exact time stamps):", ""]
    for skill in sorted({k for k, _ in given}):
        cols = _READ_COLUMNS[skill]
        lines += [f"| {skill} seed | " + " | ".join(f"{c[0]} ({c[4]})" for c in cols) + " |",
                  "|---|" + "---|" * len(cols)]
        for (sk, seed), d in sorted(given.items()):
            if sk != skill:
                continue
            cells = []
            for name, side, col, true_key, _ in cols:
                e = 1000 * ((d.inputs if side == "in" else d.outputs)[:, col] - d.extras[true_key])
                cells.append(f"{np.sqrt(np.mean(e ** 2)):.2f} [{np.abs(e).max():.2f}]")
            lines.append(f"| {seed} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)
