"""``python -m benchmarks.report --compare DIR_A DIR_B`` and the platform record of benchmark directories."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks import compare, platform_info, report
from benchmarks.harness import CONFIG_NAME, RECORDS_NAME, AttemptRecord, RunConfig

REPO = Path(__file__).resolve().parents[1]


def _make_dir(path: Path, rewards: dict[tuple[str, int, int], list[float]], platform: dict | None = None) -> Path:
    """A benchmark directory with the given rewards per (agent, seed, context), on task launch."""
    agents = sorted({a for a, _, _ in rewards})
    contexts = sorted({c for _, _, c in rewards})
    cfg = RunConfig(tasks=["launch"], agents=agents, contexts=len(contexts), attempts=2, seeds=1)
    assert contexts == cfg.context_ids
    path.mkdir()
    (path / CONFIG_NAME).write_text(json.dumps(cfg.to_dict()))
    lines = []
    for (agent, seed, ctx), rs in rewards.items():
        for k, r in enumerate(rs, start=1):
            lines.append(AttemptRecord(
                task="launch", agent=agent, seed=seed, context=ctx, split="test", attempt=k, action=[0.5, 1.0],
                reward=r, best=max(rs[:k]), regret=max(0.0, 1 - max(rs[:k])), success=False, solved=False,
                distance=0.1, begin_time=0.0, act_time=0.001, step_time=0.01, observe_time=0.0, sim_calls=0,
                skill_evals=0.0, error=None).to_json())
    (path / RECORDS_NAME).write_text("\n".join(lines) + "\n")
    if platform is not None:
        (path / platform_info.PLATFORM_NAME).write_text(json.dumps([platform]))
    return path


def _rewards(shift: float = 0.0, agents=("a", "b")) -> dict:
    rng = np.random.default_rng(0)
    out = {}
    for agent in agents:
        for ctx in (200000, 200001, 200002, 200003):
            out[(agent, 0, ctx)] = [float(rng.uniform(0.2, 0.4) + shift), float(rng.uniform(0.3, 0.5) + shift)]
    return out


def test_platform_info_describes_this_machine(tmp_path):
    info = platform_info.platform_info()
    assert info["python"] == sys.version.split()[0] and info["packages"]["mujoco"] == "3.17.0"
    assert info["cpu"] and isinstance(info["cpu_flags"], list)
    assert "mujoco 3.17.0" in platform_info.describe(info)
    platform_info.record_platform(tmp_path)
    platform_info.record_platform(tmp_path)                       # the same platform is recorded once
    assert platform_info.read_platforms(tmp_path) == [json.loads(json.dumps(info))]
    (tmp_path / platform_info.PLATFORM_NAME).write_text("{broken")
    with pytest.raises(ValueError, match="not valid JSON"):
        platform_info.read_platforms(tmp_path)


def test_a_table_compared_with_itself_differs_by_zero(tmp_path):
    a = _make_dir(tmp_path / "a", _rewards(), platform={"cpu": "CPU-A", "packages": {"mujoco": "3.17.0"}})
    text, ok = compare.format_comparison(a, a)
    assert ok and "CPU-A" in text and "Largest difference: +0.00 units" in text
    rows, only_a, only_b = compare.compare_dirs(a, a)
    assert len(rows) == 2 and not only_a and not only_b and all(r.worst == 0 for r in rows)


def test_units_are_the_difference_over_the_combined_interval(tmp_path):
    a = _make_dir(tmp_path / "a", _rewards())
    b = _make_dir(tmp_path / "b", _rewards(shift=0.05))
    rows, _, _ = compare.compare_dirs(a, b)
    sa = {s.agent: s for s in report.summarize(_load(a), attempts=2)}
    sb = {s.agent: s for s in report.summarize(_load(b), attempts=2)}
    for r in rows:
        x, y = sa[r.agent], sb[r.agent]
        half = math.hypot((x.regret_high[-1] - x.regret_low[-1]) / 2, (y.regret_high[-1] - y.regret_low[-1]) / 2)
        assert r.regret_units == pytest.approx((x.regret[-1] - y.regret[-1]) / half)
        assert r.regret_units > 0                       # B's rewards are higher: A's regret is larger


def _load(d: Path) -> list[AttemptRecord]:
    from benchmarks.harness import load_records

    return load_records(d / RECORDS_NAME, 2)[0]


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "benchmarks.report", *args], capture_output=True, text=True,
                          cwd=REPO, timeout=300)


def test_the_cli_exits_non_zero_only_beyond_the_threshold(tmp_path):
    a = _make_dir(tmp_path / "a", _rewards(), platform={"cpu": "CPU-A"})
    near = _make_dir(tmp_path / "near", _rewards(shift=0.001), platform={"cpu": "CPU-B"})
    far = _make_dir(tmp_path / "far", _rewards(shift=0.3, agents=("a", "b")))
    ok = _cli("--compare", str(a), str(near))
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "CPU-A" in ok.stdout and "CPU-B" in ok.stdout and "within the threshold 1" in ok.stdout
    bad = _cli("--compare", str(a), str(far))
    assert bad.returncode == 1 and "**beyond**" in bad.stdout and "not recorded" in bad.stdout
    assert _cli("--compare", str(a), str(far), "--threshold", "1000").returncode == 0
    for args, msg in ((("--compare", str(a), str(tmp_path / "none")), "not a benchmark output directory"),
                      (("--compare", str(a), str(near), "--threshold", "0"), "--threshold must be a positive"),
                      (("--compare", str(a), str(near), str(a)), "not both"),
                      ((), "is required")):
        res = _cli(*args)
        assert res.returncode == 2 and msg in res.stderr and "Traceback" not in res.stderr, (args, res.stderr)


def test_rows_in_one_table_only_are_listed(tmp_path):
    a = _make_dir(tmp_path / "a", _rewards(agents=("a", "b")))
    b = _make_dir(tmp_path / "b", _rewards(agents=("a", "c")))
    text, ok = compare.format_comparison(a, b)
    assert "Only in A: launch/b" in text and "Only in B: launch/c" in text and ok
    c = _make_dir(tmp_path / "c", _rewards(agents=("c",)))
    d = _make_dir(tmp_path / "d", _rewards(agents=("d",)))
    assert not compare.format_comparison(c, d)[1]                # nothing shared: not a pass


def test_repro_check_measures_a_last_bit_move(capsys):
    from benchmarks import repro_check

    smooth = repro_check.last_bit_moves("PhyPlan/Launch-v0", 3)
    assert 0 <= smooth["pos_max"] < 1e-9 and smooth["over_1mm"] == 0
    chaotic = repro_check.last_bit_moves("PhyPlan/Bridge-v0", 6)      # the disc puck: millimetres from one ulp
    assert chaotic["pos_max"] > 1e-4
    assert repro_check.main(["--ids", "PhyPlan/Launch-v0", "--actions", "2"]) == 0
    assert "| PhyPlan/Launch-v0 |" in capsys.readouterr().out
    for bad, msg in ((["--ids", "PhyPlan/Nope-v0"], "unknown id"), (["--actions", "0"], "--actions must be")):
        with pytest.raises(SystemExit) as exc:
            repro_check.main(bad)
        assert exc.value.code == 2 and msg in capsys.readouterr().err
