"""sim: the pybullet world and its characters.

Public surface: ``sim.world.World`` (``add_character``, ``add_terrain``, ``step``, ``strike``, ``snapshot``,
``close``, ``counters``, ``population``), ``sim.config.WorldConfig`` / ``CharacterSpec``,
``sim.stepping.compute_n_substeps``, ``sim.mitake.body.figure_point`` and the snapshot types in
``sim.snapshot``. Benchmarks: ``jostle.bench.sim`` (``jostle bench sim``) and ``jostle.bench.identify_experiment``
(``jostle bench identify``). Nothing is imported here, so ``import sim`` stays cheap.

Inside, ``World`` composes one population per character kind (``sim.population``): the Mitake characters
(``sim.mitake``: single rigid bodies, Mitake et al. 2009 §4, stepped as rows of numpy arrays), the
articulated characters (``sim.articulated``) and the quadrupeds (``sim.quadruped``) on the world's cube
terrain (``sim.terrain``). By default a control tick is 1/30 s: 8 physics steps of 1/240 s.
"""
