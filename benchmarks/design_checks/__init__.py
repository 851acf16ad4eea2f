"""Design checks of individual tasks: measurements over the real simulator that justify a task's sizes and ranges.

They are benchmark tools, not part of the envs (which hold only the tasks' facts):

* ``python -m benchmarks.design_checks.bounce --measure --solvability 100`` — the Bounce wedge's restitution and
  landing range per drop height, and how many sampled contexts some action solves.
* ``python -m benchmarks.design_checks.bridge --contexts 50 --seed 0 [--smooth]`` — how many Bridge contexts are
  solvable and how many need the bridge plank.
"""
