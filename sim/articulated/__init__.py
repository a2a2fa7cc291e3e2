"""Articulated characters (issue 9, after Lu): PD-tracked multibodies that take a push, keep their balance and
go back to their motion. A second character kind on ``World`` beside the Mitake body.

Modules: ``skeleton`` (``ArticulatedSkeleton``: links, joints, limits, masses; ``deepmimic_humanoid()``),
``build`` (``build_multibody``), ``reference`` (``MotionReference``: desired angles and velocities from a
clip), ``tracking`` (explicit and stable PD, joint limits), ``balance`` (SIMBICON pieces), ``assist``
(bounded root help), ``recovery`` (finer steps after a push; ``advance``), ``character``
(``ArticulatedCharacter``), ``troupe`` (``World``'s hook), ``spec`` (``ArticulatedSpec``, TOML
``configs/characters/ragdoll.toml``).

Public API: ``sim.articulated.character.ArticulatedCharacter`` (its docstring), ``recovery.advance``,
``skeleton.deepmimic_humanoid``, ``spec.ArticulatedSpec``.
In a ``World``: ``world.add_character(ArticulatedSpec(...), (x, y), heading)``; ``world.strike(name, force,
duration, at)`` pushes the link nearest ``at``; snapshots carry ``links``.
"""
