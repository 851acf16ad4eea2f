"""Headless rendering default. Imported first by :mod:`phyplan_envs`, before anything imports mujoco.

MuJoCo picks its OpenGL backend when it is first imported, so ``MUJOCO_GL`` must be set before that. We default to
EGL (works headless on the base image, see the README); a user's own choice is kept.
"""
import os

os.environ.setdefault("MUJOCO_GL", "egl")
