"""The platform a result was made on: CPU model and SIMD flags, OS, Python and the numeric packages' versions.

Results are bit-identical only on one machine with the same versions (README, "Reproducibility"); across CPUs the
last bits of MuJoCo, numpy, libm and BLAS differ. So every benchmark directory records where its records were made
(``DIR/platform.json``: one entry per platform that wrote records into it, a resumed run on another machine adds
its own), and ``python -m benchmarks.report --compare DIR_A DIR_B`` prints both, so that two tables are compared
knowingly.
"""
from __future__ import annotations

import json
import os
import platform
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

PLATFORM_NAME = "platform.json"
PACKAGES = ("mujoco", "numpy", "scipy", "torch", "scikit-learn", "gymnasium", "stable-baselines3", "mink", "daqp")
# The CPU flags that choose SIMD code paths in numpy, libm, BLAS and MuJoCo's compiled kernels.
SIMD_FLAGS = ("sse4_2", "avx", "avx2", "fma", "avx512f", "avx512dq", "avx512bw", "avx512vl", "avx512_fp16",
              "asimd", "sve")
# Environment variables that change which kernels numerical libraries pick.
ENV_VARS = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE", "NPY_DISABLE_CPU_FEATURES", "OMP_NUM_THREADS",
            "MKL_NUM_THREADS", "MUJOCO_GL")


def _cpu() -> tuple[str, list[str]]:
    """The CPU's model name and those of :data:`SIMD_FLAGS` it has (from /proc/cpuinfo where there is one)."""
    model, flags = platform.processor() or platform.machine(), set()
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return model, []
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip().lower()
        if key in ("model name", "cpu model", "hardware") and value.strip():
            model = value.strip()
        elif key in ("flags", "features"):
            flags |= set(value.split())
    return model, [f for f in SIMD_FLAGS if f in flags]


def _blas() -> list[dict[str, Any]]:
    """The BLAS/OpenMP libraries numpy loaded (threadpoolctl), with their kernels' architecture."""
    import numpy  # noqa: F401  (threadpoolctl lists the libraries that are loaded)
    from threadpoolctl import threadpool_info

    keys = ("internal_api", "version", "architecture", "num_threads")
    return [{k: lib.get(k) for k in keys} for lib in threadpool_info()]


def platform_info() -> dict[str, Any]:
    """A JSON-ready description of this machine and its numeric stack."""
    model, flags = _cpu()
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    return {
        "cpu": model, "cpu_flags": flags, "machine": platform.machine(), "cores": os.cpu_count(),
        "os": platform.platform(), "python": sys.version.split()[0], "packages": versions, "blas": _blas(),
        "env": {k: os.environ[k] for k in ENV_VARS if k in os.environ},
    }


def describe(info: dict[str, Any]) -> str:
    """One line: CPU, flags, OS, Python and the versions that matter most for bit-identical results."""
    pk = info.get("packages", {})
    blas = ", ".join(f"{b.get('internal_api')} {b.get('version')} ({b.get('architecture')})"
                     for b in info.get("blas", []) if b.get("internal_api") not in ("openmp",))
    return (f"{info.get('cpu')} [{' '.join(info.get('cpu_flags', [])) or 'no SIMD flags read'}], {info.get('os')}, "
            f"Python {info.get('python')}, " + ", ".join(f"{k} {pk.get(k)}" for k in ("mujoco", "numpy", "torch",
                                                                                        "scikit-learn")) +
            (f"; BLAS {blas}" if blas else ""))


def read_platforms(out_dir: str | Path) -> list[dict[str, Any]]:
    """The platforms recorded in a benchmark directory (empty for directories made before they were recorded)."""
    path = Path(out_dir) / PLATFORM_NAME
    if not path.exists():
        return []
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not valid JSON ({exc}); delete it to record the platform afresh") from exc
    if not isinstance(data, list) or not all(isinstance(d, dict) for d in data):
        raise ValueError(f"{path} must hold a list of platform descriptions; delete it to record it afresh")
    return data


def record_platform(out_dir: str | Path) -> dict[str, Any]:
    """Add this platform to ``DIR/platform.json`` unless it is there already; return it."""
    from phyplan_agents.files import atomic_write_json

    info = platform_info()
    known = read_platforms(out_dir)
    if info not in known:
        atomic_write_json(Path(out_dir) / PLATFORM_NAME, [*known, info])
    return info
