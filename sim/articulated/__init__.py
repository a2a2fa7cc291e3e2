"""Articulated characters (issue 9, after Lu): PD-tracked multibodies that take a push, keep their balance and
go back to their motion. A second character kind on ``World`` beside the Mitake body.

Modules: ``skeleton`` (``ArticulatedSkeleton``: links, joints, limits, masses; ``deepmimic_humanoid()``),
``build`` (``build_multibody``), ``reference`` (``MotionReference``: desired angles and velocities from a
clip), ``tracking`` (explicit and stable PD, joint limits), ``balance`` (SIMBICON pieces), ``assist``
(bounded root help), ``recovery`` (finer steps after a push; ``advance``), ``character``
(``ArticulatedCharacter``), ``troupe`` (``World``'s hook), ``spec`` (``ArticulatedSpec``, TOML
``configs/characters/ragdoll.toml``).

Public API (what benchmarks and tests use)::

    from sim.articulated.character import ArticulatedCharacter
    from sim.articulated.recovery import advance
    from sim.articulated.skeleton import deepmimic_humanoid
    from sim.articulated.spec import ArticulatedSpec

    ch = ArticulatedCharacter(client, deepmimic_humanoid(), ArticulatedSpec(), clip=None,
                              position=(x, y), heading=yaw)   # clip None: spec.walk_clip
    for each physics step:
        advance(client, [ch, ...], physics_dt)  # sim.articulated.recovery: control + stepSimulation, split
                                                # into ch.wanted_substeps while one recovers from a push
    ch.push(link, force_xyz, duration)      # link: skeleton index or name ("root" is the pelvis)
    ch.state                                # sim.snapshot.CharacterState
    ch.tracking_error_deg()                 # mean |angle| between driven joints and the clip, now
    ch.joint_angles()                       # (12, 4) local rotations, x y z w, ch.driven order
    ch.limit_excess()                       # radians beyond the joint limits now (0 inside)
    ch.external_assist_peak_n, ch.external_assist_peak_nm   # largest root assist force / torque used
    ch.falls, ch.getups                     # counters
    ch.com_state(), ch.root(), ch.link_poses(), ch.body (pybullet id)

In a ``World``: ``world.add_character(ArticulatedSpec(...), (x, y), heading)``; ``world.strike(name, force,
duration, at)`` pushes the link nearest ``at``; snapshots carry ``links``.
"""
