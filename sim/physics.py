"""One pybullet client set up the way every world (and the bench's bare baseline) uses it, and the
collision groups every body of the world belongs to (floor and cubes, characters, contactors)."""

from __future__ import annotations

import pybullet as p

from sim.config import WorldConfig

# collision groups: bit masks (group, mask); a pair collides when each one's group is in the other's mask
GROUP_FLOOR = 1
GROUP_CHARACTER = 2
GROUP_CONTACTOR = 4
MASK_FLOOR = GROUP_CHARACTER
MASK_CHARACTER = GROUP_FLOOR | GROUP_CHARACTER | GROUP_CONTACTOR
MASK_CONTACTOR = GROUP_CHARACTER


def open_client(config: WorldConfig) -> tuple[int, int]:
    """A DIRECT client with gravity, the fixed physics step, deterministic pair order and a floor.

    The world calls ``stepSimulation`` once per physics step (``numSubSteps`` 0): contact forces are
    read per step, and pybullet clears external forces after every call anyway. Returns
    (client, floor body).
    """
    client: int = p.connect(p.DIRECT)
    p.setGravity(0.0, 0.0, -config.gravity, physicsClientId=client)
    p.setPhysicsEngineParameter(fixedTimeStep=config.physics_dt, numSubSteps=0, deterministicOverlappingPairs=1,
                                numSolverIterations=config.solver_iterations, physicsClientId=client)
    floor: int = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client),
                                   physicsClientId=client)
    p.changeDynamics(floor, -1, lateralFriction=1.0, restitution=0.0, physicsClientId=client)
    p.setCollisionFilterGroupMask(floor, -1, GROUP_FLOOR, MASK_FLOOR, physicsClientId=client)
    return client, floor
