"""The layering rule, enforced: ``benchmarks -> phyplan_agents -> phyplan_envs``, arrows only go down.

``phyplan_envs`` imports nothing from ``phyplan_agents`` or ``benchmarks``; ``phyplan_agents`` never imports
``benchmarks``. The AST test reads every module of the two packages, including imports inside functions and
``importlib.import_module("...")`` calls with a literal name; the subprocess test imports and runs the envs with the
upper layers made unimportable.
"""
from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# package -> the top-level packages it must not import (the layers above it)
FORBIDDEN = {"phyplan_envs": ("phyplan_agents", "benchmarks"), "phyplan_agents": ("benchmarks",)}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imported_modules(source: str, module: str, is_package: bool = False) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``source``, the code of module ``module``.

    Covers ``import a.b``, ``from a import b`` (also relative: resolved against ``module``), at any depth (inside
    functions, classes, ``if``/``try`` blocks), and ``importlib.import_module("a.b")`` / ``__import__("a")`` with a
    literal name.
    """
    package = module.split(".") if is_package else module.split(".")[:-1]
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                if node.level - 1 > len(package):
                    raise ValueError(f"{module}:{node.lineno}: relative import beyond the top-level package")
                base = package[:len(package) - (node.level - 1)]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module
            found.append((node.lineno, name))
            found += [(node.lineno, f"{name}.{alias.name}") for alias in node.names]
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            f = node.func
            fname = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            if fname in ("import_module", "__import__"):
                found.append((node.lineno, node.args[0].value))
    return found


def upward_imports(source: str, module: str, is_package: bool = False) -> list[str]:
    """The imports in ``source`` (module ``module``) that point to a layer above the module's package."""
    banned = FORBIDDEN.get(module.split(".")[0], ())
    return [f"{module}:{line} imports {name}" for line, name in imported_modules(source, module, is_package)
            if name.split(".")[0] in banned]


def _sources():
    for package in FORBIDDEN:
        for path in sorted((ROOT / package).rglob("*.py")):
            yield path


def test_the_scan_sees_every_module():
    paths = list(_sources())
    names = {_module_name(p) for p in paths}
    assert {"phyplan_envs.tasks.launch", "phyplan_envs.skill_scenes.hit", "phyplan_agents.phyplan.composer",
            "phyplan_agents.dqn.cache", "phyplan_agents.skills.contract"} <= names
    assert len(paths) > 40


def test_no_upward_imports():
    bad = []
    for path in _sources():
        bad += upward_imports(path.read_text(encoding="utf-8"), _module_name(path), path.name == "__init__.py")
    assert not bad, "upward imports (the arrows are benchmarks -> phyplan_agents -> phyplan_envs):\n" + "\n".join(bad)


@pytest.mark.parametrize("snippet, module", [
    ("from phyplan_agents.phyplan import queries as q", "phyplan_envs.tasks.launch"),
    ("def f():\n    import benchmarks.splits\n", "phyplan_envs.skill_scenes.hit"),
    ("from ...phyplan_agents import skills", "phyplan_envs.tasks.launch"),      # relative, out of the package
    ("import importlib\nm = importlib.import_module('benchmarks.splits')", "phyplan_agents.dqn.cache"),
    ("class A:\n    def g(self):\n        from benchmarks import splits\n", "phyplan_agents.oracle"),
])
def test_the_scan_catches_upward_imports(snippet, module):
    """The checker is not vacuous: each of these is an upward import it must report."""
    try:
        bad = upward_imports(snippet, module)
    except ValueError as exc:             # a relative import climbing out of the package is an error too
        bad = [str(exc)]
    assert bad, snippet


def test_downward_and_sibling_imports_are_allowed():
    assert not upward_imports("from phyplan_envs import assets\nfrom .chains import chain_for\n",
                              "phyplan_agents.phyplan.predictor")
    assert not upward_imports("from ..tasks.slide import FACTS\n", "phyplan_envs.skill_scenes.slide")
    assert imported_modules("from . import swing\n", "phyplan_envs.skill_scenes", is_package=True) == [
        (1, "phyplan_envs.skill_scenes"), (1, "phyplan_envs.skill_scenes.swing")]


def module_edges(sources: dict[str, tuple[str, bool]]) -> dict[str, set[str]]:
    """The import graph of the modules ``sources`` (name -> (source, is_package)): an edge from a module to every
    module of ``sources`` it imports at any depth (lazy imports inside functions included). ``from a import b``
    imports the module ``a.b`` if there is one, else ``a``; ``import a.b`` imports ``a.b`` (the longest prefix that
    is a module of ``sources``)."""
    def known(name: str) -> str | None:
        while name and name not in sources:
            name = name.rpartition(".")[0]
        return name or None

    edges = {}
    for module, (source, is_package) in sources.items():
        package = module.split(".") if is_package else module.split(".")[:-1]
        out = set()
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(package[:len(package) - (node.level - 1)] + ([node.module] if node.module else []))
                names = [f"{base}.{a.name}" if f"{base}.{a.name}" in sources else base for a in node.names]
            else:
                continue
            out |= {m for m in map(known, names) if m is not None and m != module}
        edges[module] = out
    return edges


def import_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles of a graph: its strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return cycles


def test_no_import_cycle_inside_phyplan_envs():
    """No module of phyplan_envs imports, directly or through others, a module that imports it back, lazy imports
    inside functions included (a lazy cycle is a hidden dependency both ways: the executor and the arm-free flight
    get what they need passed in instead)."""
    sources = {_module_name(p): (p.read_text(encoding="utf-8"), p.name == "__init__.py")
               for p in sorted((ROOT / "phyplan_envs").rglob("*.py"))}
    cycles = import_cycles(module_edges(sources))
    assert not cycles, "import cycles in phyplan_envs:\n" + "\n".join(" <-> ".join(c) for c in cycles)


def test_the_cycle_check_catches_a_lazy_cycle():
    """The check is not vacuous: the env base importing the arm-free flight inside a function, and the flight the
    base inside another (the cycle the executor removed), is a cycle; sibling and package imports are not."""
    lazy = {"phyplan_envs.base": ("def f():\n    from .panda.robot.flight import ArmFreeFlight\n", False),
            "phyplan_envs.panda": ("", True), "phyplan_envs.panda.robot": ("", True),
            "phyplan_envs.panda.robot.flight": ("def g():\n    from ...base import PhyPlanEnv\n", False)}
    assert import_cycles(module_edges(lazy)) == [["phyplan_envs.base", "phyplan_envs.panda.robot.flight"]]
    fine = {"phyplan_envs": ("from .base import PhyPlanEnv\n", True),
            "phyplan_envs.base": ("from . import assets\nfrom .assets import arena\n", False),
            "phyplan_envs.assets": ("import numpy\n", False)}
    assert import_cycles(module_edges(fine)) == []


_BLOCKED_RUN = textwrap.dedent("""
    import importlib, pkgutil, sys

    class Block:
        # a meta-path finder that makes the upper layers unimportable
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in ("phyplan_agents", "benchmarks"):
                raise ImportError(f"blocked upper layer: {name}")
            return None

    sys.meta_path.insert(0, Block())
    for name in ("phyplan_agents", "benchmarks"):
        try:
            importlib.import_module(name)
        except ImportError:
            pass
        else:
            raise SystemExit(f"the blocker let {name} through")

    import gymnasium as gym
    import numpy as np
    import phyplan_envs

    for mod in pkgutil.walk_packages(phyplan_envs.__path__, "phyplan_envs."):
        importlib.import_module(mod.name)
    for task in phyplan_envs.TASKS:
        env = gym.make(phyplan_envs.env_id(task))
        obs, info = env.reset(seed=0)
        low, high = env.action_space.low, env.action_space.high
        obs, reward, terminated, truncated, info = env.step((low + high) / 2)
        assert terminated and np.isfinite(reward), (task, reward)
        assert env.unwrapped.facts is not None
        env.close()
    from phyplan_envs import skill_scenes, splits
    assert len(skill_scenes.generate("throw", 3, seed=0)) == 3
    assert splits.context_seeds("test", 2) == [200000, 200001]
    leaked = sorted(m for m in sys.modules if m.split(".")[0] in ("phyplan_agents", "benchmarks"))
    assert not leaked, leaked
    print("envs ran without the upper layers:", ", ".join(phyplan_envs.TASKS))
""")


def test_envs_import_and_run_without_agents_and_benchmarks():
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", _BLOCKED_RUN], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "envs ran without the upper layers" in out.stdout
