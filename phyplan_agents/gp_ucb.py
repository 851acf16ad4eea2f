"""GP-UCB on a predictor's error: the one Gaussian-process wrapper and the one beta of the project.

After each real attempt an agent knows the action ``a``, the reward the environment gave ``r`` and the reward its
model predicted ``r_hat(a)``. The paper's adaptation (Algorithm 2) fits a scikit-learn ``GaussianProcessRegressor``
to the pairs ``(a, r - r_hat(a))`` and corrects the predictor of every later candidate:

    score(a) = r_hat(a) + mu(a) + sqrt(beta) * sigma(a)          (beta = 0.25, the paper's value: :data:`BETA`)

:class:`ResidualGP` is that GP. PhyPlan (:mod:`phyplan_agents.phyplan.agent`, ``r_hat`` = the skill chain) and
DQN-Adapted (:mod:`phyplan_agents.dqn.agents`, ``r_hat`` = the Q-network) both use it. It also takes vector
residuals: PhyPlan's ``residual="position"`` option models the error of the predicted final xy instead (two outputs,
one kernel).

Inputs are normalised to the unit box of the action bounds, so one length scale means the same in every dimension.
Kernel: ``ConstantKernel * RBF + WhiteKernel`` (the paper and the reference code use an RBF GP; the white-noise term
absorbs the simulator's small chaotic scatter). By default the hyperparameters are fitted by maximum marginal
likelihood within bounds; with one or two points they are barely identified, so the bounds (:data:`REWARD_PRIOR`,
:data:`POSITION_PRIOR`) are set to the scales of this problem. ``optimize=False`` keeps the prior's initial values
(DQN-Adapted's default).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

from typing import Any

import numpy as np

BETA = 0.25   # the paper's beta ("we use beta = 0.25")


@dataclass(frozen=True)
class KernelPrior:
    """Initial value and (low, high) bounds of the kernel hyperparameters.

    ``amplitude``: prior variance of the residual; ``length_scale``: in units of the action range; ``noise``:
    white-noise variance.
    """

    amplitude: tuple[float, tuple[float, float]]
    length_scale: tuple[float, tuple[float, float]]
    noise: tuple[float, tuple[float, float]]


REWARD_PRIOR = KernelPrior(amplitude=(0.01, (1e-4, 1.0)),        # reward residual std 0.1 (0.01 ... 1)
                           length_scale=(0.1, (0.01, 1.0)),
                           noise=(1e-4, (1e-6, 1e-2)))            # std 0.01 reward (0.001 ... 0.1)
"""Reward residuals: a few hundredths of reward, varying over a few percent of the action range."""

POSITION_PRIOR = KernelPrior(amplitude=(2.5e-3, (1e-6, 1.0)),    # xy error std 5 cm (1 mm ... 1 m)
                             length_scale=(0.3, (0.05, 3.0)),    # chain errors vary slowly over the action space
                             noise=(1e-5, (1e-8, 1e-3)))          # simulator scatter ~3 mm (0.1 mm ... 3 cm)
"""Final-position residuals (m): a systematic chain error varies slowly over the action space."""


class ResidualGP:
    """GP model of a predictor's error over a box-bounded action space (scalar or vector residuals).

    Args:
        low, high: the action bounds (A,), used to normalise inputs to [0, 1]^A.
        beta: the UCB weight (default 0.25, the paper's).
        seed: seeds the optimiser restarts (``random_state``); default 0.
        n_restarts: extra optimiser restarts from random hyperparameters (default 2).
        prior: the kernel's hyperparameter initial values and bounds (default :data:`REWARD_PRIOR`).
        optimize: fit the hyperparameters by maximum likelihood within the prior's bounds (default true); false
            keeps the prior's initial values.

    Before any data, ``mu = 0`` and ``sigma = 0``: the predictor is used as it is.
    """

    def __init__(self, low, high, beta: float = BETA, seed: int = 0, n_restarts: int = 2,
                 prior: KernelPrior = REWARD_PRIOR, optimize: bool = True):
        self.low = np.asarray(low, dtype=np.float64)
        self.span = np.asarray(high, dtype=np.float64) - self.low
        if np.any(self.span <= 0):
            raise ValueError(f"action bounds must have high > low, got low={low}, high={high}")
        if beta < 0:
            raise ValueError(f"beta must be >= 0, got {beta}")
        self.beta = float(beta)
        self.seed = int(seed)
        self.n_restarts = int(n_restarts)
        self.prior = prior
        self.optimize = bool(optimize)
        self.reset()

    def _norm(self, actions) -> np.ndarray:
        return (np.atleast_2d(np.asarray(actions, dtype=np.float64)) - self.low) / self.span

    def reset(self) -> None:
        """Forget all data (a new context)."""
        self.X = np.zeros((0, len(self.low)))
        self.y: list[np.ndarray] = []
        self.gp: Any = None          # the fitted sklearn GaussianProcessRegressor (None before any data)

    def add(self, action, residual) -> None:
        """Record one real attempt's residual (observed - predicted; a number or a vector) and refit."""
        r = np.atleast_1d(np.asarray(residual, dtype=np.float64))
        if not np.all(np.isfinite(r)):
            raise ValueError(f"residual must be finite, got {residual}")
        if self.y and r.shape != self.y[0].shape:
            raise ValueError(f"residual shape {r.shape} differs from the earlier {self.y[0].shape}")
        self.X = np.vstack([self.X, self._norm(action)])
        self.y.append(r)
        self.fit()

    def set_data(self, actions, residuals) -> None:
        """Replace the data by ``actions`` (N, A) and their ``residuals`` (N,) or (N, k), then fit once."""
        x = self._norm(actions)
        r = np.asarray(residuals, dtype=np.float64)
        r = r.reshape(len(r), -1)
        if len(r) != len(x) or len(x) == 0 or not np.all(np.isfinite(r)):
            raise ValueError(f"set_data needs one finite residual per action (N >= 1), got {len(x)} actions and "
                             f"residuals of shape {np.shape(residuals)}")
        self.X = x
        self.y = list(r)
        self.fit()

    def fit(self) -> None:
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

        p = self.prior
        kernel = (ConstantKernel(p.amplitude[0], p.amplitude[1]) * RBF(p.length_scale[0], p.length_scale[1])
                  + WhiteKernel(p.noise[0], p.noise[1]))
        gp = GaussianProcessRegressor(kernel=kernel, normalize_y=False, n_restarts_optimizer=self.n_restarts,
                                      optimizer="fmin_l_bfgs_b" if self.optimize else None,
                                      random_state=self.seed)
        y = np.vstack(self.y)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            gp.fit(self.X, y[:, 0] if y.shape[1] == 1 else y)
        self.gp = gp

    @property
    def n(self) -> int:
        return len(self.y)

    def predict(self, actions) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and standard deviation of the residual at ``actions`` (N, A).

        Shapes: ``(N,)`` for scalar residuals, ``(N, k)`` for vector ones (before any data: zeros of shape (N,)).
        """
        x = self._norm(actions)
        if self.gp is None:
            return np.zeros(len(x)), np.zeros(len(x))
        mu, sd = self.gp.predict(x, return_std=True)
        if mu.ndim == 2 and sd.ndim == 1:
            sd = np.repeat(sd[:, None], mu.shape[1], axis=1)
        return mu, sd

    def correction(self, actions) -> np.ndarray:
        """``mu + sqrt(beta) * sigma`` (N,): what GP-UCB adds to a predicted reward (scalar residuals)."""
        mu, sd = self.predict(actions)
        if mu.ndim != 1:
            raise ValueError("correction() is for scalar (reward) residuals; use predict() for vector ones")
        return mu + np.sqrt(self.beta) * sd
