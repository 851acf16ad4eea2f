"""The DQN baselines of the paper (DQN-Simple and DQN-Adapted, after PHYRE's DQN), on stable-baselines3.

Pieces (see docs/dqn.md for the design, the measured figures and the commands):

* :mod:`.grid`: the discretisation of each task's action box and the action encoding the network reads.
* :mod:`.cache`: the simulation cache (random train contexts x random grid actions, simulated once, ``.npz``).
* :mod:`.policy`: an SB3 ``DQNPolicy`` whose Q-network scores every action from (image features, action encoding).
* :mod:`.training`: SB3's ``DQN`` trained from a replay buffer pre-filled from the cache (no re-simulation).
* :mod:`.models`: trained models on disk with checksums; the shipped ones are in ``phyplan_agents/dqn_models/``.
* :mod:`.agents`: ``dqn-simple`` and ``dqn-adapted`` on the agent protocol.
* ``python -m phyplan_agents.dqn.train`` (``make baselines``) and ``python -m phyplan_agents.dqn.ablation``: the
  command-line tools (the quick evaluation of the trained agents is ``python -m benchmarks.dqn_eval``, on the
  harness; the grid-resolution check on dev contexts ``python -m benchmarks.dqn_grid``).

Importing this package does not import torch or SB3; the submodules do.
"""
