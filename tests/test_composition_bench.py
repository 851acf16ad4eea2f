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
    """A flight that grazes the wedge's incline (incidence beyond the general bounce's 85 degrees, at 0.17 m/s into
    the face: no skill's domain, and so for 13 x 13 neighbouring actions 3 mrad apart) has no prediction; a flight
    that misses the wedge has one, close to the simulator's landing; a row below reward 0.95 is not a solution and
    is skipped."""
    path = tmp_path / "contexts.csv"
    graze = (0.0, 0.9382, 0.3, 0.0, 0.5236)                  # hit along +x onto the incline 0.3 m out, turned 30 deg
    clear = (0.3, 1.0, 1.0, math.pi / 2, 0.0)                # the wedge at the far corner, off the flight's path
    _write(path, [(0, 0.99, graze), (0, 0.97, clear), (0, 0.5, clear)])
    r = composition.solutions("launch-bounce", str(path))
    assert r["solved"] == 2 and r["no_prediction"] == 1
    assert np.isfinite(r["median_m"]) and r["median_m"] < 0.02
    errors = [c["error_m"] for c in r["contexts"]]                 # per row: no prediction, predicted, not solved
    assert len(errors) == 3 and math.isnan(errors[0]) and errors[1] < 0.02 and math.isnan(errors[2])
    assert [c["best"] for c in r["contexts"]] == [0.99, 0.97, 0.5]


def _record(agent, seed, context, attempt, regret):
    from benchmarks.harness.records import AttemptRecord

    return AttemptRecord(task="launch-bounce", agent=agent, seed=seed, context=context, split="test",
                         attempt=attempt, action=[0.0] * 5, reward=1 - regret, best=1 - regret, regret=regret,
                         success=False, solved=False, distance=0.1, begin_time=0.0, act_time=0.0, step_time=0.0,
                         observe_time=0.0, sim_calls=0, skill_evals=0)


def test_regret_by_context_averages_the_last_attempt_over_run_seeds(tmp_path):
    path = tmp_path / "attempts.jsonl"
    recs = [_record("a", 0, 7, 1, 0.8), _record("a", 0, 7, 2, 0.4), _record("a", 1, 7, 1, 0.6),
            _record("a", 1, 7, 2, 0.2), _record("a", 0, 8, 1, 0.5), _record("a", 0, 8, 2, 0.1),
            _record("a", 1, 8, 1, 0.5), _record("a", 1, 8, 2, 0.3)]
    path.write_text("".join(r.to_json() + "\n" for r in recs))
    got = composition.regret_by_context(str(path), "launch-bounce")
    assert set(got) == {7, 8} and got[7][0] == "a"
    assert got[7][1] == pytest.approx(0.3) and got[8][1] == pytest.approx(0.2)
    path.write_text("".join(r.to_json() + "\n" for r in recs + [_record("b", 0, 9, 1, 0.5)]))
    with pytest.raises(ValueError, match="--records"):
        composition.regret_by_context(str(path), "launch-bounce")


@pytest.mark.parametrize("command, argv, named", [
    ("composition", ["--section", "solutions"], "--solutions"),
    ("composition", ["--section", "solutions", "--solutions", "/nonexistent/contexts.csv"], "--solutions"),
    ("composition", ["--tasks", "jumping"], "--tasks"),
    ("composition", ["--section", "cost", "--records", __file__], "--records"),
    ("composition", ["--section", "solutions", "--solutions", __file__, "--records", "/nonexistent.jsonl"],
     "--records"),
    ("sysid_diagnostics", ["--iterations", "0"], "--iterations"),
    ("sysid_diagnostics", ["--paddles", "2"], "--paddles"),
    ("sysid_diagnostics", ["--tasks", "paddles-varied", "--paddles", "0"], "--paddles"),
    ("depth", ["--depths", "0"], "--depths"),
    ("depth", ["--actions", "0"], "--actions"),
    ("depth", ["--task", "bounce"], "--task"),
    ("depth", ["--split", "train"], "--split"),
    ("depth", ["--split", "dev", "--section", "accuracy"], "--split"),
    ("depth", ["--redraw", "--plot", "x.png"], "--redraw"),
])
def test_bad_arguments_are_refused_by_name(command, argv, named, capsys):
    """The measuring commands of composition and depth refuse a bad argument with exit code 2, naming it."""
    import importlib

    main = importlib.import_module(f"benchmarks.{command}").main
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    assert named in capsys.readouterr().err


def test_damaged_records_are_refused_by_name(tmp_path, capsys):
    """A --records file that is not a benchmark's records stops the command with exit code 2, naming the option."""
    solutions = tmp_path / "contexts.csv"
    _write(solutions, [(0, 0.5, (0.3, 1.0, 1.0, math.pi / 2, 0.0))])      # not a solution: no rollout needed
    records = tmp_path / "attempts.jsonl"
    records.write_text('{"not": "a record"}\n')
    with pytest.raises(SystemExit) as e:
        composition.main(["--tasks", "launch-bounce", "--section", "solutions", "--solutions", str(solutions),
                          "--records", str(records)])
    assert e.value.code == 2 and "--records" in capsys.readouterr().err


def test_accuracy_splits_the_paths_through_an_edge(capsys):
    """The accuracy table's edge columns: Launch has no face, so no path meets an edge ("-" for their error), and
    its other paths land within centimetres of the simulator."""
    composition.main(["--tasks", "launch", "--section", "accuracy", "--contexts", "1", "--actions", "4"])
    row = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| launch |")]
    assert len(row) == 1
    cells = [c.strip() for c in row[0].strip("|").split("|")]
    assert cells[1] == "4" and cells[4] == "0%" and cells[5] == "0%" and cells[6] == "-"
    assert float(cells[7]) < 0.02


def test_depth_redraw_runs_nothing_and_draws_from_the_figures(tmp_path, capsys):
    """``--redraw`` prints the tables of the JSON's figures and draws the figure, with no section run (no "N=2"
    progress line)."""
    import json

    from benchmarks import depth

    figures = tmp_path / "depth.json"
    figures.write_text(json.dumps({"2": {
        "decision": {"agent": "phyplan", "contexts": 3, "cpu_s": 0.25, "wall_s": 0.26, "cpu_max_s": 0.3,
                     "evaluations": 704.0},
        "accuracy-varied-dev": {k: {"actions": 4, "mean_m": 0.125, "p90_m": 0.25, "no_prediction": 0.0}
                                for k in ("true", "nominal")},
        "regret": {"phyplan": {"regret1": 0.125, "regret1_hw": 0.01, "regret5": 0.0625, "regret5_hw": 0.005,
                               "decision_s": 0.25, "wall_s": 1.0}}}}))
    png = tmp_path / "depth.png"
    assert depth.main(["--redraw", "--json", str(figures), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "N=2\n" not in out and "| 2 |" in out and "0.25 (0.26; 704)" in out and "0.125 / 0.062" in out
    assert "| the true restitution | 12.5 / 25.0, 0% |" in out
    assert png.stat().st_size > 1000


def test_depth_decision_counts_the_candidates_it_times():
    """The decision section's candidates are the agent's own count of chain evaluations: at N = 1 the MCTS's and
    the refinement's (a grid of 11 per round), so more than one round's grid and the same on a second run."""
    from benchmarks import depth

    a, b = depth.decision(1, 1), depth.decision(1, 1)
    assert a["evaluations"] == b["evaluations"] > 11
    assert 0 < a["cpu_per_evaluation_s"] <= a["cpu_s"]
