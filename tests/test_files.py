"""phyplan_agents.files: the one checksum + atomic-write helper (and that the shipped files still verify)."""
from __future__ import annotations

import hashlib
import json

import pytest

from phyplan_agents.files import atomic_path, atomic_write_bytes, atomic_write_json, sha256_file, sha256_matches


def test_sha256_and_match(tmp_path):
    p = tmp_path / "x.bin"
    data = bytes(range(256)) * 5000                      # > one 1 MiB block
    p.write_bytes(data)
    assert sha256_file(p) == hashlib.sha256(data).hexdigest()
    assert sha256_matches(p, hashlib.sha256(data).hexdigest()) == (True, sha256_file(p))
    ok, digest = sha256_matches(p, None)
    assert not ok and digest == sha256_file(p)


def test_atomic_writes_replace_and_leave_no_temporary(tmp_path):
    p = tmp_path / "m.json"
    atomic_write_bytes(p, b"old")
    atomic_write_json(p, {"b": 1, "a": [1, 2]}, indent=1)
    assert p.read_text() == json.dumps({"a": [1, 2], "b": 1}, indent=1, sort_keys=True) + "\n"
    assert [f.name for f in tmp_path.iterdir()] == ["m.json"]


def test_a_failed_write_keeps_the_old_file(tmp_path):
    p = tmp_path / "w.pt"
    p.write_bytes(b"good")
    with pytest.raises(RuntimeError, match="disk"):
        with atomic_path(p) as tmp:
            tmp.write_bytes(b"half")
            raise RuntimeError("disk full")
    assert p.read_bytes() == b"good" and [f.name for f in tmp_path.iterdir()] == ["w.pt"]


def test_shipped_files_verify():
    from phyplan_agents.dqn.models import read_manifest, shipped_model_dir
    from phyplan_agents.skills.io import WEIGHTS_DIR

    metas = sorted(WEIGHTS_DIR.glob("*.json"))
    assert metas
    for js in metas:
        meta = json.loads(js.read_text())
        assert sha256_matches(WEIGHTS_DIR / meta["weights_file"], meta["sha256"])[0], js.name
    models = read_manifest()["models"]
    assert models
    for task, entry in models.items():
        assert sha256_matches(shipped_model_dir() / entry["file"], entry["sha256"])[0], task
