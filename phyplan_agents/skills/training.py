"""Training skill models: data loss (+ physics-residual loss for PINNs), Adam then optional L-BFGS.

Loss (the paper's Section "Learning Physics-Informed Skill Models"): ``L = L_D + alpha * L_P`` with ``L_D`` the MSE of
the normalised outputs on the data points and ``L_P`` the mean of the squared residuals of the governing equations
(:mod:`phyplan_agents.skills.physics`) on collocation points plus the initial-condition residuals. An ``nn`` model
uses ``L_D`` only. Collocation points: ``colloc_factor`` (4, as in the paper) times the number of data points, drawn
once, uniformly over the skill's input ranges, from the training seed; as many initial-condition points (t = 0) as
data points.

Everything is seeded: the network's initial weights, the collocation points and the mini-batches come from
``seed``; with one torch thread the result is bitwise reproducible.
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import torch

from phyplan_envs import skill_scenes
from phyplan_envs.skill_scenes import SkillData

from . import bounce_law, physics
from .contract import skill_spec
from .models import HIDDEN_LAYERS, LEARNT_PARAMS, WIDTH, SkillModel, check_kind

VAL_SEED = 1_000_003     # the validation sets' seed (never used for training data)
VAL_SIZE = 2000


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation settings. Defaults: Adam at 2e-3 decaying to 2e-5, then L-BFGS.

    Attributes:
        steps: Adam steps (each on one mini-batch of data and of collocation points).
        lr, lr_final: Adam learning rate, decayed geometrically from ``lr`` to ``lr_final`` over ``steps``.
        param_lr: Adam learning rate of the learnt physical parameters (mu), decayed by the same factor.
        batch_data, batch_colloc: mini-batch sizes (the whole set when smaller).
        colloc_factor: collocation points per data point (the paper: 4).
        phys_weight: alpha, the weight of the physics loss.
        lbfgs_steps: L-BFGS iterations on the full sets after Adam (0: none). Table 1 of the paper uses L-BFGS.
        hidden, width: the network (default Table 1: 8 hidden layers of 40 units; tests use smaller ones).
    """

    steps: int = 3000
    lr: float = 2e-3
    lr_final: float = 2e-5
    param_lr: float = 5e-3
    batch_data: int = 256
    batch_colloc: int = 512
    colloc_factor: int = 4
    phys_weight: float = 1.0
    lbfgs_steps: int = 0
    hidden: int = HIDDEN_LAYERS
    width: int = WIDTH

    def __post_init__(self):
        if self.steps < 0 or self.lbfgs_steps < 0 or self.steps + self.lbfgs_steps == 0:
            raise ValueError("steps and lbfgs_steps must be >= 0 and not both 0")
        if not (self.lr > 0 and self.lr_final > 0 and self.param_lr > 0):
            raise ValueError("learning rates must be positive")
        if self.batch_data < 1 or self.batch_colloc < 1 or self.colloc_factor < 1:
            raise ValueError("batch sizes and colloc_factor must be >= 1")
        if self.hidden < 1 or self.width < 1:
            raise ValueError("hidden and width must be >= 1 (the paper: 8 hidden layers of 40)")


# What `python -m phyplan_agents.skills.train --all` (make skills) trains and ships: (skill, kind) -> settings.
# Sizes and steps: the shipped models meet the chain's ~1 cm needs (docs/skills.md, "Chain accuracy"); L-BFGS does
# most of the final fitting (Adam alone plateaus near a normalised loss of 1e-4 with mini-batches).
SHIPPED: dict[tuple[str, str], dict[str, Any]] = {
    ("swing", "pinn"): {"n_data": 1000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("slide", "pinn"): {"n_data": 1000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("throw", "pinn"): {"n_data": 1000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("swing", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("slide", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("throw", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("hit", "nn"): {"n_data": 1500, "config": TrainConfig(steps=4000, lbfgs_steps=300)},
    ("hit_free", "nn"): {"n_data": 1500, "config": TrainConfig(steps=4000, lbfgs_steps=300)},
    ("bounce", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
}
SHIPPED_SEED = 0

# What `python -m phyplan_agents.skills.train --conditioned` trains and ships: the hidden-physics track's
# parameter-conditioned skills (data over the training space only; phyplan_envs.skill_scenes.*_cond). Sizes and steps:
# each under ~2 min of one core (data + training), errors in docs/skills.md ("Conditioned skills").
CONDITIONED: dict[tuple[str, str], dict[str, Any]] = {
    ("slide_cond", "pinn"): {"n_data": 2000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("hit_cond", "nn"): {"n_data": 2500, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("hit_free_cond", "nn"): {"n_data": 2500, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("bounce_cond", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=300)},
}

# What `python -m phyplan_agents.skills.train --general-bounce` trains and ships: the general-incidence bounce
# (phyplan_envs.skill_scenes.bounce_general) under the Bounce-v0 wedge contact and the varied track's impact pair,
# PINN (the reflection law of .bounce_law) and NN. Errors and times in docs/skills.md ("General-incidence bounce").
# param_lr 0.05: the law's contact time (in ms, ~7) moves ~1 % a step; at 5e-3 it stalls near 5.8 ms in 3000 steps.
GENERAL_BOUNCE: dict[tuple[str, str], dict[str, Any]] = {
    ("bounce_general", "pinn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_general", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
    ("bounce_general_cond", "pinn"): {"n_data": 3000,
                                      "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_general_cond", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
    # the walls (80-90 degrees): the same settings
    ("bounce_wall", "pinn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_wall", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
    ("bounce_wall_cond", "pinn"): {"n_data": 3000,
                                   "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_wall_cond", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
}

# What `python -m phyplan_agents.skills.train --paddles` (make skills-paddles) trains and ships: the Paddles task's new
# skills (phyplan_envs.skill_scenes.{wide,glide,bounce_general_low}, hit_free's slow hand-over); the shipped skills
# above are untouched. Sizes and steps: ~30 min of one core in all (data + training); errors in docs/skills.md
# ("Paddles skills").
PADDLES: dict[tuple[str, str], dict[str, Any]] = {
    ("swing_wide", "pinn"): {"n_data": 2000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("swing_wide", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("hit_wide", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=300)},
    ("hit_free_slow", "nn"): {"n_data": 3000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("throw_wide", "pinn"): {"n_data": 2000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("throw_wide", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("glide", "pinn"): {"n_data": 3000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("glide", "nn"): {"n_data": 3000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
    ("bounce_general_low", "pinn"): {"n_data": 3000,
                                     "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_general_low", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
    ("bounce_general_low_cond", "pinn"): {"n_data": 3000,
                                          "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_general_low_cond", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
}


# What `python -m phyplan_agents.skills.train --bouncing-paddles` trains and ships: the skills a ball falling through
# bouncing paddles needs beyond the others' ranges (phyplan_envs.skill_scenes.bounce_general's bounce at up to 10 m/s,
# .wide's throw at up to 6 m/s upwards and 1.6 s), with the settings of their narrower twins. Errors in
# docs/skills.md ("Bouncing paddles").
BOUNCING_PADDLES: dict[tuple[str, str], dict[str, Any]] = {
    ("bounce_general_fast", "pinn"): {"n_data": 3000,
                                      "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_general_fast", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
    ("throw_fast", "pinn"): {"n_data": 2000, "config": TrainConfig(steps=1500, lbfgs_steps=500)},
    ("throw_fast", "nn"): {"n_data": 2000, "config": TrainConfig(steps=4000, lbfgs_steps=500)},
}


# What `python -m phyplan_agents.skills.train --exact-impacts` trains and ships: the bounce off PaddlesVaried-v3's
# exact impacts (phyplan_envs.skill_scenes.bounce_exact), with the settings of bounce_general_low_cond. Errors in
# docs/skills.md ("Exact impacts").
EXACT_IMPACTS: dict[tuple[str, str], dict[str, Any]] = {
    ("bounce_general_exact_cond", "pinn"): {"n_data": 3000,
                                            "config": TrainConfig(steps=3000, lbfgs_steps=500, param_lr=0.05)},
    ("bounce_general_exact_cond", "nn"): {"n_data": 3000, "config": TrainConfig(steps=3000, lbfgs_steps=500)},
}


def shipped_settings(skill: str, kind: str) -> dict[str, Any]:
    """The shipped training settings of a model (``n_data``, ``config``), or ``{}`` if it is not shipped."""
    for table in (SHIPPED, CONDITIONED, GENERAL_BOUNCE, PADDLES, BOUNCING_PADDLES, EXACT_IMPACTS):
        if (skill, kind) in table:
            return table[(skill, kind)]
    return {}


def _t(a: np.ndarray) -> torch.Tensor:
    return torch.as_tensor(np.asarray(a), dtype=torch.float32)


def new_model(skill: str, kind: str, data: SkillData, seed: int, hidden: int = HIDDEN_LAYERS,
              width: int = WIDTH) -> SkillModel:
    """An untrained model: input normalisation from the skill's ranges, output normalisation from ``data``."""
    spec = skill_spec(skill)
    lo = np.array([r[0] for r in spec.ranges])
    hi = np.array([r[1] for r in spec.ranges])
    out_mean = data.outputs.mean(axis=0)
    out_scale = data.outputs.std(axis=0)
    out_scale = np.where(out_scale > 1e-6, out_scale, 1.0)
    params = LEARNT_PARAMS.get(spec.name, {}) if kind == "pinn" else {}
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(int(seed))
        return SkillModel(spec.name, kind, (lo + hi) / 2, (hi - lo) / 2, out_mean, out_scale, hidden=hidden,
                          width=width, params=params)


def sample_domain(skill: str, n: int, gen: torch.Generator, t_zero: bool = False) -> torch.Tensor:
    """``n`` points uniform over the skill's input ranges (with the time input set to 0 if ``t_zero``)."""
    spec = skill_spec(skill)
    lo = torch.tensor([r[0] for r in spec.ranges], dtype=torch.float32)
    hi = torch.tensor([r[1] for r in spec.ranges], dtype=torch.float32)
    x = lo + (hi - lo) * torch.rand(n, len(lo), generator=gen)
    if t_zero:
        x[:, spec.time_input] = 0.0
    return x


def evaluate(model: SkillModel, data: SkillData) -> dict[str, Any]:
    """Validation errors of ``model`` on ``data``.

    Returns ``nmse`` (the mean over outputs of MSE / variance of that output in ``data``: 0 is perfect, 1 is as good
    as predicting the mean), and per output ``mse`` (physical units squared), ``rmse`` and ``max_abs`` (physical).
    """
    pred = model.predict(_t(data.inputs)).double().numpy()
    err = pred - data.outputs
    mse = (err ** 2).mean(axis=0)
    var = data.outputs.var(axis=0)
    names = model.outputs
    return {
        "nmse": float(np.mean(mse / np.where(var > 0, var, 1.0))),
        "mse": {k: float(v) for k, v in zip(names, mse)},
        "rmse": {k: float(math.sqrt(v)) for k, v in zip(names, mse)},
        "max_abs": {k: float(v) for k, v in zip(names, np.abs(err).max(axis=0))},
        "n": len(data),
    }


def fit(skill: str, kind: str | None, data: SkillData, seed: int = 0, config: TrainConfig = TrainConfig(),
        val: SkillData | None = None, progress: bool = False) -> SkillModel:
    """Train a skill model on ``data`` (from :func:`phyplan_envs.skill_scenes.generate`).

    Args:
        skill: skill name (aliases like ``"sliding"`` accepted); kind: ``"pinn"``, ``"nn"`` or None (the default).
        data: the training set; seed: seeds the initial weights, collocation points and mini-batches.
        config: optimisation settings; val: a validation set (its errors go into ``model.meta``).
        progress: show a tqdm progress bar.

    Returns the trained model with ``meta`` filled (data size, seed, config, losses, validation errors, time).
    """
    spec = skill_spec(skill)
    kind = check_kind(spec.name, kind)
    if data.skill != spec.name:
        raise ValueError(f"data is for skill {data.skill!r}, not {spec.name!r}")
    n = len(data)
    if n < 2:
        raise ValueError("need at least 2 training samples")
    t0 = time.perf_counter()
    c0 = time.process_time()
    model = new_model(spec.name, kind, data, seed, config.hidden, config.width)
    gen = torch.Generator().manual_seed(int(seed) + 7919)
    xd, yd = _t(data.inputs), _t(data.outputs)
    pinn = kind == "pinn"
    law = spec.name in bounce_law.LAW_SKILLS     # an algebraic law: no time input, no initial conditions
    x0 = None
    if pinn and law:
        xc = bounce_law.collocation(spec.name, config.colloc_factor * n, gen)
    elif pinn:
        xc = sample_domain(spec.name, config.colloc_factor * n, gen)
        x0 = sample_domain(spec.name, n, gen, t_zero=True)

    def losses(idx_d=None, idx_c=None, idx_0=None):
        xb, yb = (xd, yd) if idx_d is None else (xd[idx_d], yd[idx_d])
        ld = (((model(xb) - yb) / model.out_scale) ** 2).mean()
        if not pinn:
            return ld, ld, torch.zeros(())
        cb = xc if idx_c is None else xc[idx_c]
        if law:
            rs = bounce_law.residuals(model, cb)
        else:
            ib = x0 if idx_0 is None else x0[idx_0]
            rs = physics.residuals(model, cb) + physics.initial_residuals(model, ib)
        lp = torch.stack([(r ** 2).mean() for r in rs]).mean()
        return ld + config.phys_weight * lp, ld, lp

    def batch(size: int, total: int):
        return None if total <= size else torch.randint(0, total, (size,), generator=gen)

    net_params = list(model.net.parameters())
    phys_params = list(model.phys.parameters())
    opt = torch.optim.Adam(net_params, lr=config.lr)
    opt_p = torch.optim.Adam(phys_params, lr=config.param_lr) if phys_params else None
    decay = (config.lr_final / config.lr) ** (1.0 / max(config.steps, 1))
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=config.steps + config.lbfgs_steps, desc=f"{spec.name}-{kind} (n={n})", unit="step")
    history = []
    model.train()
    for step in range(config.steps):
        f = decay ** step
        for g in opt.param_groups:
            g["lr"] = config.lr * f
        if opt_p is not None:
            for g in opt_p.param_groups:
                g["lr"] = config.param_lr * f
        loss, ld, lp = losses(batch(config.batch_data, n),
                              batch(config.batch_colloc, len(xc)) if pinn else None,
                              batch(max(1, config.batch_colloc // 4), len(x0)) if x0 is not None else None)
        opt.zero_grad(set_to_none=True)
        if opt_p is not None:
            opt_p.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        if opt_p is not None:
            opt_p.step()
        if step % 100 == 0 or step == config.steps - 1:
            rec = {"step": step, "loss": float(loss.detach()), "data": float(ld.detach()), "physics": float(lp.detach())}
            rec.update(model.params)
            history.append(rec)
            if bar is not None:
                bar.set_postfix({k: f"{v:.3g}" for k, v in rec.items() if k != "step"}, refresh=False)
        if bar is not None:
            bar.update(1)
    if config.lbfgs_steps:
        lb = torch.optim.LBFGS(net_params + phys_params, lr=1.0, max_iter=config.lbfgs_steps,
                               history_size=50, tolerance_grad=1e-12, tolerance_change=1e-15,
                               line_search_fn="strong_wolfe")
        count = [0]

        def closure():
            lb.zero_grad(set_to_none=True)
            loss, _, _ = losses()
            loss.backward()
            count[0] += 1
            return loss

        before = {k: v.detach().clone() for k, v in model.state_dict().items()}
        lb.step(closure)
        loss, ld, lp = losses()
        if not torch.isfinite(loss):      # a diverged line search: keep the Adam result
            model.load_state_dict(before)
            loss, ld, lp = losses()
        rec = {"step": config.steps + count[0], "loss": float(loss.detach()), "data": float(ld.detach()),
               "physics": float(lp.detach())}
        rec.update(model.params)
        history.append(rec)
        if bar is not None:
            bar.update(config.lbfgs_steps)
    if bar is not None:
        bar.close()
    model.eval()
    final = history[-1] if history else {}
    model.meta = {
        "skill": spec.name, "kind": kind, "inputs": list(spec.inputs), "outputs": list(spec.outputs),
        "input_units": list(spec.input_units), "output_units": list(spec.output_units),
        "input_ranges": [list(r) for r in spec.ranges],
        "n_data": n, "n_collocation": config.colloc_factor * n if pinn else 0, "seed": int(seed),
        "data_seed": int(data.seed), "config": asdict(config),
        "train_loss": final.get("loss"), "train_data_loss": final.get("data"),
        "train_physics_loss": final.get("physics"),
        "params": model.params, "physics": physics.physics_constants(spec.name) if pinn else {},
        "train_seconds": round(time.perf_counter() - t0, 2),
        "train_cpu_seconds": round(time.process_time() - c0, 2), "history": history,
    }
    if val is not None:
        model.meta["validation"] = evaluate(model, val)
        model.meta["val_mse"] = model.meta["validation"]["nmse"]
    return model


def validation_set(skill: str, n: int = VAL_SIZE, progress: bool = False) -> SkillData:
    """The fixed validation set of a skill (seed :data:`VAL_SEED`)."""
    return skill_scenes.generate(skill, n, VAL_SEED, progress=progress)


def train_skill(skill: str, kind: str | None = None, n_data: int | None = None, seed: int = SHIPPED_SEED,
                config: TrainConfig | None = None, n_val: int = VAL_SIZE, progress: bool = False) -> SkillModel:
    """Generate data (seed ``seed``) and a validation set, then :func:`fit`. Defaults: the shipped settings."""
    spec = skill_spec(skill)
    kind = check_kind(spec.name, kind)
    shipped = shipped_settings(spec.name, kind)
    n_data = int(n_data or shipped.get("n_data", 1000))
    config = config or shipped.get("config", TrainConfig())
    t0 = time.perf_counter()
    data = skill_scenes.generate(spec.name, n_data, seed, progress=progress)
    val = validation_set(spec.name, n_val, progress=progress) if n_val else None
    gen_s = time.perf_counter() - t0
    model = fit(spec.name, kind, data, seed=seed, config=config, val=val, progress=progress)
    model.meta["data_seconds"] = round(gen_s, 2)
    if spec.name == "slide":
        model.meta["true_mu"] = skill_scenes.measured_slide_mu()
    return model


def with_steps(config: TrainConfig, factor: float) -> TrainConfig:
    """``config`` with its step counts scaled by ``factor`` (at least 1 Adam step)."""
    return replace(config, steps=max(1, int(config.steps * factor)), lbfgs_steps=int(config.lbfgs_steps * factor))
