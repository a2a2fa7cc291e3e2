"""sim: the pybullet world of single-rigid-body characters (Mitake et al. 2009 §4).

Public surface: ``sim.world.World`` (``add_character``, ``step``, ``snapshot``, ``close``, ``counters``),
``sim.config.WorldConfig`` / ``CharacterSpec``, ``sim.stepping.compute_n_substeps`` and the snapshot
types in ``sim.snapshot``. Nothing is imported here, so ``import sim`` stays cheap.
"""
