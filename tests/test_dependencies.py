"""Every third-party module the packages import is declared in setup.cfg (install_requires or an extra)."""
from __future__ import annotations

import ast
import configparser
import importlib.metadata as md
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("phyplan_envs", "phyplan_agents", "benchmarks")
OPTIONAL = {"ray": "ray"}          # imported only behind a guard, declared as an extra


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _requirement_names(text: str) -> set[str]:
    out = set()
    for line in text.splitlines():
        line = line.split("#")[0].strip()
        if line:
            out.add(_norm(re.split(r"[<>=!~\[; ]", line, maxsplit=1)[0]))
    return out


def _declared() -> tuple[set[str], set[str]]:
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    required = _requirement_names(cfg["options"]["install_requires"])
    extras = set()
    for value in cfg["options.extras_require"].values():
        extras |= _requirement_names(value)
    return required, extras


def _imports(path: Path) -> set[str]:
    mods = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            mods |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            mods.add(node.module.split(".")[0])
    return mods


def third_party_imports() -> dict[str, set[str]]:
    """Top-level module -> files importing it, for every non-stdlib, non-project import in the packages."""
    found: dict[str, set[str]] = {}
    for pkg in PACKAGES:
        for f in sorted((ROOT / pkg).rglob("*.py")):
            for m in _imports(f):
                if m in sys.stdlib_module_names or m in PACKAGES or m == "__future__":
                    continue
                found.setdefault(m, set()).add(str(f.relative_to(ROOT)))
    return found


def test_every_import_is_declared():
    required, extras = _declared()
    dists = md.packages_distributions()
    missing = {}
    for module, files in third_party_imports().items():
        names = {_norm(d) for d in dists.get(module, [module])}
        if module in OPTIONAL:
            ok = _norm(OPTIONAL[module]) in extras
        else:
            ok = bool(names & required)
        if not ok:
            missing[module] = sorted(files)[:3]
    assert not missing, f"imported but not declared in setup.cfg install_requires: {missing}"


def test_the_check_sees_imports(tmp_path):
    # the scan finds a nested third-party import and ignores stdlib and project imports
    f = tmp_path / "m.py"
    f.write_text("import os\nfrom phyplan_agents import base\n\ndef g():\n    from scipy import stats\n")
    assert _imports(f) == {"os", "phyplan_agents", "scipy"}
    assert "scipy" in _requirement_names("numpy>=1\nscipy>=1.10\n")
