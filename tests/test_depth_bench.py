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



def test_the_accuracy_section_writes_its_figures_to_the_json_file(tmp_path, capsys):
    """``--section accuracy --json FILE`` on the nominal task keeps the figures (the per-action arrival speeds that
    :func:`depth.accuracy` also returns are not written: they made the file unwritable)."""
    import json

    out = tmp_path / "depth.json"
    assert depth.main(["--section", "accuracy", "--depths", "1", "--actions", "2", "--json", str(out)]) == 0
    row = json.loads(out.read_text())["1"]["accuracy"]
    assert row["actions"] == 2 and np.isfinite(row["mean_m"]) and "arrival" not in row
    assert "chain landing error over 2 chain actions" in capsys.readouterr().out


def test_paths_replays_each_cells_best_attempt_and_counts_the_paddles_it_touches():
    """Two cells on one test context at N = 3: in one the best attempt is a chain action (the ball touches every
    paddle), in the other it puts paddle 1 at the nearest offset, 0.45 m, and paddle 2 0.8 m on, where the ball
    flies over paddle 2 (on this context every release angle does, for paddle 1's offsets up to 0.47 m and paddle 2's
    from 0.7 to 0.9 m), and a worse attempt of that cell is the chain action: only best attempts count."""
    from types import SimpleNamespace

    from benchmarks.design_checks.paddles_actions import chain_actions, make
    from phyplan_envs import splits

    ctx = splits.context_seeds("test", 1)[0]
    env = make(3, record_trajectory=True)
    env.reset(seed=ctx)
    chain = chain_actions(env, env.context, 1, np.random.default_rng(0))[0]
    skips = np.array([chain[0], 0.45, 0.8])
    rec = lambda seed, action, reward: SimpleNamespace(seed=seed, context=ctx, action=list(action), reward=reward)
    records = [rec(0, chain, 0.9), rec(0, skips, 0.2), rec(1, chain, 0.3), rec(1, skips, 0.5),
               rec(1, chain, None)]
    out = depth.paths(records, 3)
    assert out == {"every_paddle": 0.5, "touched": 2.5}


def test_the_cost_sections_chain_rows_are_distinct_copies_of_the_chain_actions():
    """The chain computes a repeated row once: the cost section's batch of chain actions has no two rows alike, each
    within JITTER of its chain action (a tenth of it on the release angle) and inside the bounds."""
    lo, hi = np.array([0.2, 0.45, 0.45]), np.array([0.5, 0.9, 0.9])
    acts = np.array([[0.3, 0.6, 0.7], [0.45, 0.9, 0.45]])
    rows = depth.distinct_copies(acts, 64, np.random.default_rng(0), lo, hi)
    assert rows.shape == (64, 3) and len(np.unique(rows, axis=0)) == 64
    assert np.array_equal(rows[:2], acts)
    base = np.resize(acts, (64, 3))
    assert np.all(np.abs(rows - base) <= depth.JITTER * np.array([0.1, 1.0, 1.0]) + 1e-15)
    assert np.all((rows >= lo) & (rows <= hi))
