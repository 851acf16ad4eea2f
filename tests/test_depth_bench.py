"""benchmarks.depth: the hidden-physics accuracy section (its arguments: test_composition_bench.py)."""
from __future__ import annotations

import numpy as np

from benchmarks import depth


def test_varied_accuracy_compares_the_true_and_the_nominal_restitution():
    """The conditioned chain at each test context's true restitution lands near the simulator at N = 1. Tolerance:
    the test restitutions lie outside the skills' training range, and on 60 actions of these contexts the error was
    2.8 cm mean and 4.2 cm p90; 10 cm is well above either, far below a wrong-physics miss (tens of cm at N = 2)."""
    r = depth.accuracy_varied(1, 2, seed=0)
    assert len(r["physics"]) == depth.VARIED_CONTEXTS
    assert all(0.0 < p[0] < 1.0 for p in r["physics"])
    for key in ("true", "nominal"):
        assert r[key]["actions"] == 2 * depth.VARIED_CONTEXTS
        assert 0.0 <= r[key]["no_prediction"] <= 1.0
    assert np.isfinite(r["true"]["mean_m"]) and r["true"]["mean_m"] < 0.10

