"""Validation of the general-incidence bounce skills: the law their data follow, PINN vs NN vs the analytic
reflection on held-out arrivals, and today's vertical-drop bounce skill against the general one on its own range.

    python -m benchmarks.skills_bounce_general                    # the shipped weights (docs/skills.md)
    python -m benchmarks.skills_bounce_general --n 200 --directory /tmp/w --json /tmp/bg.json

Held-out sets (seed ``--seed``, never a training or validation seed; one random stream per set): ``--n`` arrivals
drawn as the training data are (:func:`phyplan_envs.skill_scenes.bounce_general.sample`), at the nominal
restitution and over a restitution range (varied physics: the training and the test space). Errors are RMS in mm/s
per incline-frame component and ``overall`` = RMS of the error vector's length. Each row's truth is one arrival at
a random phase; ``vs mean`` scores against the mean over ``--phases`` arrival phases of the same input (the model's
own error without the phase's scatter), and the row ``phase mean`` is that mean itself (the floor against single
arrivals). ``law`` is the law of :mod:`phyplan_agents.skills.bounce_law` with the PINN's learnt constants,
``textbook`` the frictionless reflection without gravity during the contact.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np
import torch

from phyplan_envs import assets
from phyplan_envs import skill_scenes as ss
from phyplan_envs.skill_scenes import bounce_general as bg
from phyplan_agents.skills import bounce_law, load_skill
from phyplan_agents.skills.bounce_general import load_general_bounce

SEED = 2_000_003
G = assets.GRAVITY


def held_out(physics: str, restitution, n: int, seed: int, salt: int, phases: int) -> dict:
    """``n`` arrivals (inputs, one-phase outputs, phase-mean outputs) under ``physics``."""
    rng = np.random.default_rng([seed, salt])
    x, y, ex = bg.sample(n, rng, physics, restitution=restitution)
    scene = bg.GeneralBounceScene(physics)
    mean = np.zeros_like(y)
    for i in range(n):
        for k in range(phases):
            mean[i] += scene.bounce(x[i, 0], x[i, 1], x[i, 2:], (k + 0.5) / phases)["v_out"]
    return {"x": x, "y": y, "mean": mean / phases, "extras": ex}


def rms(pred: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """RMS errors in mm/s: per component (down, across, normal) and of the error vector."""
    err = (pred - truth) * 1e3
    out = {c: float(np.sqrt((err[:, j] ** 2).mean())) for j, c in enumerate(bg.COLUMNS)}
    out["overall"] = float(np.sqrt((err ** 2).sum(axis=1).mean()))
    return out


def law_figures(sets: list[dict]) -> dict[str, float]:
    """What the data say about the law (pooled over ``sets``): friction, gravity along the face, restitution."""
    x = np.concatenate([s["x"] for s in sets])
    y = np.concatenate([s["y"] for s in sets])
    e, a, vd, va, vn = x.T
    tau = (y[:, 0] - vd) / (G * np.sin(a)) * 1e3
    dev = -y[:, 2] / vn - e
    beta = float(np.linalg.lstsq((1 - e)[:, None], dev, rcond=None)[0][0])
    contact = np.concatenate([s["extras"]["contact_s"] for s in sets]) * 1e3
    return {"n": len(x), "across_max_abs": float(np.abs(y[:, 1] - va).max()),
            "gain_ms_mean": float(tau.mean()), "gain_ms_std": float(tau.std()),
            "contact_ms_mean": float(contact.mean()), "beta_lstsq": beta,
            "restitution_scatter": float((dev - beta * (1 - e)).std()),
            "normal_resid_rms_mm": float(np.sqrt(((y[:, 2] + (e + beta * (1 - e)) * vn) ** 2).mean()) * 1e3)}


def gravity_off(physics: str, n: int, seed: int) -> float:
    """Largest |v_out_down - v_in_down| (m/s) over ``n`` arrivals with gravity switched off."""
    rng = np.random.default_rng([seed, 99])
    scene = bg.GeneralBounceScene(physics)
    e_range = bg.E_NOMINAL_RANGE if physics == "nominal" else bg.COND_PARAM.train
    worst = 0.0
    for _ in range(n):
        e, a = rng.uniform(*e_range), rng.uniform(*bg.ANGLE)
        r = scene.bounce(e, a, bg.draw_velocity(rng), rng.uniform(0.01, 0.99), gravity=False)
        worst = max(worst, abs(r["v_out"][0] - r["v_in"][0]), abs(r["v_out"][1] - r["v_in"][1]))
    return worst


def validation(physics: str, n: int, seed: int, phases: int, directory) -> tuple[list[dict], dict, dict]:
    """Rows of the validation table for one physics, the law figures and the models' learnt constants."""
    pinn = load_general_bounce(physics, "pinn", directory)
    nn = load_general_bounce(physics, "nn", directory)
    p = pinn.params
    if physics == "nominal":
        specs = [("e = 0.9487 (task wedge)", bg.E_NOMINAL), ("e in [0.8, 1]", bg.E_NOMINAL_RANGE)]
    else:
        par = bg.COND_PARAM
        specs = [("e = 0.8 (nominal)", par.nominal), ("train space [0.7, 0.9]", par.train),
                 ("test space [0.4, 0.7) U (0.9, 0.99]", lambda rng: par.sample(rng, "test"))]
    rows, sets = [], []
    for salt, (label, spec) in enumerate(specs):
        h = held_out(physics, spec, n, seed, 10 * (physics == "varied") + salt, phases)
        sets.append(h)
        xt = torch.as_tensor(h["x"], dtype=torch.float32)
        preds = {"PINN": pinn.model.predict(xt).double().numpy(), "NN": nn.model.predict(xt).double().numpy(),
                 "law (PINN's constants)": bounce_law.law(h["x"], p["contact_ms"], p["restitution_excess"]),
                 "textbook reflection": bounce_law.textbook(h["x"]), "phase mean": h["mean"]}
        for name, pred in preds.items():
            r = rms(pred, h["y"])
            r["vs_mean"] = rms(pred, h["mean"])["overall"]
            rows.append({"physics": physics, "set": label, "model": name, **r})
    return rows, law_figures(sets), {"pinn": p, "train": {k: pinn.model.meta.get(k) for k in
                                                          ("train_seconds", "train_cpu_seconds", "data_seconds")},
                                     "nn_train": {k: nn.model.meta.get(k) for k in
                                                  ("train_seconds", "train_cpu_seconds", "data_seconds")}}


def subsumption(n: int, seed: int, phases: int, directory) -> list[dict]:
    """Today's bounce skill vs the general one (nominal physics) on today's scene: vertical drops on the 45 degree
    incline, and today's whole range. The general skill's output is advanced by one free-flight step (today's scene
    records the velocity one step after the contact ends). ``vs mean``: against the mean over ``phases`` arrival
    phases of the same input (the general scene, the same physics, advanced by the same step)."""
    old = load_skill("bounce")
    gens = {k: load_general_bounce("nominal", k, directory) for k in ("pinn", "nn")}
    s, incline = ss.bounce_scene()
    general = bg.GeneralBounceScene("nominal")
    rng = np.random.default_rng([seed, 77])
    rows = []
    vertical = np.empty((n, 4)), np.empty((n, 2))
    for i in range(n):
        e, v = rng.uniform(*ss.BOUNCE_E), rng.uniform(*ss.BOUNCE_V_VER)
        r = ss.bounce_one(s, incline, e, math.pi / 4, v, 0.0)
        vertical[0][i] = (e, math.pi / 4, r["v_in"][2], r["v_in"][0])
        vertical[1][i] = (r["v_out"][2], r["v_out"][0])
    full = ss.generate("bounce", n, seed)
    for label, (x, y) in (("vertical drops on 45 deg", vertical), ("today's whole range", (full.inputs,
                                                                                            full.outputs))):
        v_world = np.stack([x[:, 3], np.zeros(len(x)), x[:, 2]], axis=1)
        normal = np.stack([np.sin(x[:, 1]), np.zeros(len(x)), np.cos(x[:, 1])], axis=1)
        inside = gens["pinn"].in_domain(v_world, normal, x[:, 0]).numpy()
        x, y, v_world, normal = x[inside], y[inside], v_world[inside], normal[inside]
        mean = np.zeros_like(y)
        for i, (e, a, vv, vh) in enumerate(x):
            basis = bg.incline_basis(a)
            for k in range(phases):
                w = basis.T @ general.bounce(e, a, basis @ (vh, 0.0, vv), (k + 0.5) / phases)["v_out"]
                mean[i] += (w[2] - G * assets.TIMESTEP, w[0])
        mean /= phases
        preds = {"today's bounce NN": old.predict(torch.as_tensor(x, dtype=torch.float32)).double().numpy()}
        for kind, g in gens.items():
            w = g.predict(v_world, normal, x[:, 0]).double().numpy()
            preds[f"general {kind.upper()}"] = np.stack([w[:, 2] - G * assets.TIMESTEP, w[:, 0]], axis=1)
        preds["phase mean"] = mean
        for name, pred in preds.items():
            err = (pred - y) * 1e3
            dm = (pred - mean) * 1e3
            rows.append({"set": f"{label} ({int(inside.sum())} of {len(inside)} in the domain)", "model": name,
                         "v_ver": float(np.sqrt((err[:, 0] ** 2).mean())),
                         "v_hor": float(np.sqrt((err[:, 1] ** 2).mean())),
                         "overall": float(np.sqrt((err ** 2).sum(axis=1).mean())),
                         "vs_mean": float(np.sqrt((dm ** 2).sum(axis=1).mean()))})
    return rows


def _table(rows: list[dict], cols: list[str], keys: list[str]) -> str:
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join(str(r[k]) if isinstance(r[k], str) else f"{r[k]:.1f}" for k in keys) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.skills_bounce_general", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--n", type=int, default=1000, help="arrivals per held-out set (default 1000)")
    p.add_argument("--phases", type=int, default=8, help="arrival phases per input for the phase mean (default 8)")
    p.add_argument("--seed", type=int, default=SEED, help=f"held-out seed (default {SEED})")
    p.add_argument("--directory", default=None, help="weights folder (default: the shipped weights)")
    p.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = p.parse_args(argv)
    for name, v, low in (("--n", args.n, 1), ("--phases", args.phases, 1)):
        if v < low:
            p.error(f"{name} must be at least {low}, got {v}")
    if args.seed < 0 or args.seed in (0, 1_000_003):
        p.error(f"--seed must be a non-negative seed other than the training (0) and validation (1000003) ones, "
                f"got {args.seed}")
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    out = {"rows": [], "law": {}, "models": {}}
    for physics in bg.PHYSICS:
        rows, law, models = validation(physics, args.n, args.seed, args.phases, args.directory)
        out["rows"] += rows
        law["gravity_off_max_abs"] = gravity_off(physics, 200, args.seed)
        out["law"][physics], out["models"][physics] = law, models
    out["subsumption"] = subsumption(args.n, args.seed, args.phases, args.directory)
    for physics in bg.PHYSICS:
        f, m = out["law"][physics], out["models"][physics]
        print(f"\n## {bg.SKILL_OF_PHYSICS[physics]} ({physics} physics): the law in {f['n']} held-out arrivals")
        print(f"across: max |v_out - v_in| = {f['across_max_abs']:.1e} m/s; gravity off: max tangential change "
              f"{f['gravity_off_max_abs']:.1e} m/s")
        print(f"down: (v_out - v_in) / (g sin a) = {f['gain_ms_mean']:.3f} +- {f['gain_ms_std']:.3f} ms "
              f"(contact {f['contact_ms_mean']:.3f} ms); PINN contact_ms {m['pinn']['contact_ms']:.3f}")
        print(f"normal: -v_out/v_in = e + beta (1 - e), beta = {f['beta_lstsq']:.4f} (least squares), scatter "
              f"{f['restitution_scatter']:.4f} (RMS {f['normal_resid_rms_mm']:.1f} mm/s); PINN restitution_excess "
              f"{m['pinn']['restitution_excess']:.4f}")
        print(f"training (PINN / NN): {m['train']} / {m['nn_train']}\n")
        rows = [r for r in out["rows"] if r["physics"] == physics]
        print(_table(rows, ["held-out set", "model", "down", "across", "normal", "overall", "overall vs mean"],
                     ["set", "model", "v_down", "v_across", "v_normal", "overall", "vs_mean"]))
    print("\n## today's bounce vs the general one (nominal physics), on today's scene (mm/s RMS)\n")
    print(_table(out["subsumption"], ["held-out set", "model", "v_ver", "v_hor", "overall", "overall vs mean"],
                 ["set", "model", "v_ver", "v_hor", "overall", "vs_mean"]))
    print(f"\n{time.perf_counter() - t0:.0f} s")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
