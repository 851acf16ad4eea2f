"""benchmarks.composition: the solutions section; the arguments of composition, sysid_diagnostics and depth."""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from benchmarks import composition

NAMES = ("phi", "theta", "wedge_distance", "wedge_angle", "wedge_yaw")


def _write(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["task", "seed", "best_reward"] + [f"action_{n}" for n in NAMES])
        w.writeheader()
        for seed, reward, action in rows:
            w.writerow({"task": "launch-bounce", "seed": seed, "best_reward": reward,
                        **{f"action_{n}": v for n, v in zip(NAMES, action)}})


def test_solutions_counts_the_actions_the_chain_cannot_predict(tmp_path):
    """A flight onto the wedge's vertical back wall has no prediction; a flight that misses the wedge has one, close
    to the simulator's landing; a row below reward 0.95 is not a solution and is skipped."""
    path = tmp_path / "contexts.csv"
    wall = (0.0, 1.2, 0.35, 0.0, 0.0)                        # hit along +x onto the back wall 0.35 m out
    clear = (0.3, 1.0, 1.0, math.pi / 2, 0.0)                # the wedge at the far corner, off the flight's path
    _write(path, [(0, 0.99, wall), (0, 0.97, clear), (0, 0.5, clear)])
    r = composition.solutions("launch-bounce", str(path))
    assert r["solved"] == 2 and r["no_prediction"] == 1
    assert np.isfinite(r["median_m"]) and r["median_m"] < 0.02


@pytest.mark.parametrize("command, argv, named", [
    ("composition", ["--section", "solutions"], "--solutions"),
    ("composition", ["--section", "solutions", "--solutions", "/nonexistent/contexts.csv"], "--solutions"),
    ("composition", ["--tasks", "jumping"], "--tasks"),
    ("sysid_diagnostics", ["--iterations", "0"], "--iterations"),
    ("depth", ["--depths", "0"], "--depths"),
    ("depth", ["--actions", "0"], "--actions"),
    ("depth", ["--task", "bounce"], "--task"),
])
def test_bad_arguments_are_refused_by_name(command, argv, named, capsys):
    """The measuring commands of composition and depth refuse a bad argument with exit code 2, naming it."""
    import importlib

    main = importlib.import_module(f"benchmarks.{command}").main
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    assert named in capsys.readouterr().err
