"""sim: the pybullet world of single-rigid-body characters (Mitake et al. 2009 §4).

Public surface: ``sim.world.World`` (``add_character``, ``step``, ``strike``, ``snapshot``, ``close``,
``counters``, ``character``), ``sim.config.WorldConfig`` / ``CharacterSpec``,
``sim.stepping.compute_n_substeps``, ``sim.mitake.body.figure_point`` and the snapshot types in
``sim.snapshot``. Benchmarks: ``sim.bench`` (``jostle bench sim``) and ``sim.bench_identify``
(``jostle bench identify``). Nothing is imported here, so ``import sim`` stays cheap.

Inside, every character is a row of numpy arrays (``sim.mitake.crowd``); once per control tick (30 Hz by
default, 8 physics steps of 1/240 s) the AI (``sim.mitake.ai``), the state machine (``sim.mitake.states``) and the
bounded balance controller (``sim.mitake.balance``, ``sim.mitake.control``) run for all of them at once, and the
world makes three pybullet calls per character: two reads and one velocity write.
"""
