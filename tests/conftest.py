"""Test set-up: headless rendering and one thread, before anything imports mujoco or torch."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("OMP_NUM_THREADS", "1")
