"""Design checks of individual tasks: measurements over the real simulator that justify a task's sizes and ranges.

They are benchmark tools, not part of the envs (which hold only the tasks' facts):

* ``python -m benchmarks.design_checks.bounce --measure --solvability 100 [--sawtooth]`` — the Bounce wedge's
  restitution and landing range per drop height, how many sampled contexts some action solves, and (``--sawtooth``)
  Bounce-v0's landing range against the drop height at two timesteps.
* ``python -m benchmarks.design_checks.bridge --contexts 50 --seed 0 [--smooth]`` — how many Bridge contexts are
  solvable and how many need the bridge plank; ``--chaos``: how far its landings move for tiny action changes and a
  halved timestep.
* ``python -m benchmarks.design_checks.chaos --actions 200`` — the same chaos and timestep figures for any nominal id.
* ``python -m benchmarks.design_checks.hidden_physics`` — the varied tasks: restitution and friction set vs measured
  (:mod:`.contacts`), timestep convergence, Bounce's monotone range, episode cost, the nominal-physics planner.

Every sampled check takes ``--seed`` and ``--seed-step`` (:mod:`.seeds`): ``--seed 7310000 --seed-step 7919`` measures
a figure on contexts outside every split.
"""
