"""Localisation error of the perception pipeline: what it reads from RGB-D pictures against the state observation.

For each task and context, the env is reset in ``obs_mode="rgbd"`` and the pipeline
(:func:`phyplan_agents.perception.perceive`) reads the state vector from the picture; a second env in state mode,
reset to the same context, gives the truth. Errors in millimetres: the goal centre (xy distance), the object's
start (xyz distance) and every further state entry (absolute error). Contexts whose scene the pipeline flags as
unreadable (goal hidden or out of view, a failed fit) are counted, not scored::

    python -m benchmarks.perception --contexts 100              # the first 100 test contexts of every task
    python -m benchmarks.perception --contexts 20 --image-size 128

Prints a Markdown table (``--out FILE`` also writes it).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

IMAGE_SIZE = 256


def measure(task: str, seeds, image_size: int = IMAGE_SIZE, env_kwargs=None) -> dict:
    """Per-entry errors (m) of the pipeline on ``task`` over contexts ``seeds``, and the flagged contexts.
    ``env_kwargs``: further ``gym.make`` keywords of both envs (e.g. ``camera_noise``)."""
    import gymnasium as gym

    import phyplan_envs
    from phyplan_agents.perception import perceive

    kw = dict(env_kwargs or {})
    env = gym.make(phyplan_envs.env_id(task), obs_mode="rgbd", image_size=image_size, with_panda=False,
                   **kw).unwrapped
    ref = gym.make(phyplan_envs.env_id(task), obs_mode="state", with_panda=False, **kw).unwrapped
    cam, names = env.camera_model("obs"), env.state_names
    errors, flagged, seconds = [], [], 0.0
    try:
        for s in seeds:
            obs, info = env.reset(seed=int(s))
            truth, _ = ref.reset(options={"context": info["context"]})
            t0 = time.perf_counter()
            p = perceive(task, obs, cam, env.facts, names)
            seconds += time.perf_counter() - t0
            if not p.ok:
                flagged.append((int(s), "; ".join(p.problems)))
                continue
            errors.append(p.state - np.asarray(truth, dtype=np.float64))
    finally:
        env.close()
        ref.close()
    e = np.array(errors).reshape(-1, len(names))
    rows = {"goal": np.linalg.norm(e[:, 0:2], axis=1), "object": np.linalg.norm(e[:, 2:5], axis=1)}
    for i, n in enumerate(names[5:], 5):
        rows[n] = np.abs(e[:, i])
    return {"rows": rows, "flagged": flagged, "n": len(list(seeds)), "seconds": seconds}


def table(results: dict[str, dict], image_size: int, split: str) -> str:
    lines = [f"Localisation error of `phyplan_agents.perception` ({image_size} x {image_size} RGB-D, `{split}` "
             f"contexts), mm; flagged = contexts the pipeline reported as unreadable (not scored).", "",
             "| task | object | contexts scored | mean (mm) | p90 (mm) | max (mm) | flagged |",
             "|---|---|---|---|---|---|---|"]
    for task, res in results.items():
        for k, (name, err) in enumerate(res["rows"].items()):
            mm = 1000 * err
            stats = (f"{mm.mean():.2f} | {np.percentile(mm, 90):.2f} | {mm.max():.2f}" if len(mm)
                     else "- | - | -")
            flagged = f"{len(res['flagged'])}/{res['n']}" if k == 0 else ""
            lines.append(f"| {task} | {name} | {len(mm)} | {stats} | {flagged} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    from phyplan_envs import TRACKS
    from phyplan_envs.splits import SPLITS, context_seeds

    tasks = TRACKS["nominal"]        # Paddles has no scene reader (docs/depth.md)

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--contexts", type=int, default=100, help="contexts per task (the first N of the split)")
    p.add_argument("--split", default="test", choices=list(SPLITS))
    p.add_argument("--tasks", nargs="+", default=list(tasks), choices=list(tasks))
    p.add_argument("--image-size", type=int, default=IMAGE_SIZE)
    p.add_argument("--out", default=None, help="also write the table to this file")
    a = p.parse_args(argv)
    if a.contexts < 1:
        p.error("--contexts must be >= 1")
    seeds = context_seeds(a.split, a.contexts)
    results = {t: measure(t, seeds, a.image_size) for t in a.tasks}
    text = table(results, a.image_size, a.split)
    flagged = [f"* {task} context {seed}: {why}" for task, res in results.items() for seed, why in res["flagged"]]
    if flagged:
        text += "\n\nFlagged contexts:\n\n" + "\n".join(flagged)
    ms = {t: 1000 * r["seconds"] / max(r["n"], 1) for t, r in results.items()}
    text += "\n\nPipeline time per picture: " + ", ".join(f"{t} {v:.0f} ms" for t, v in ms.items())
    text += f"\n\nCommand: `python -m benchmarks.perception --contexts {a.contexts} --split {a.split}" \
            f"{'' if a.image_size == IMAGE_SIZE else f' --image-size {a.image_size}'}`"
    print(text)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
