"""sim.quadruped: a four-legged character on a terrain of unit cubes people build (He, Tsai, Ko, Lu).

- ``sim.terrain`` (the world's): ``TerrainGrid`` (the cubes and the paper's placing rules), ``TerrainBody`` (its twin),
  ``TerrainConfig``;
- ``planner``: A* with eq. (2)'s weights, ``CostField`` (kept in step with the grid), ``Route``, ``replan``;
- ``footsteps``: motion models (walk, climb up/down, turn left/right, turn back) and footholds;
- ``legs``: 5-point Bezier swing curves clear of the cubes, dynamic time warping;
- ``motion_models``: the models' body keyframes and their DTW joins;
- ``skeleton``: the laikago URDF as the paper's Fig. 4 skeleton, closed-form leg IK;
- ``gait``: ``Locomotion`` (path → footsteps → legs → body pose), pure numpy;
- ``body``: ``QuadrupedBody`` (kinematic in pybullet while walking, physical when knocked over);
- ``herd``: ``Quadrupeds``, their population in the World (``World.add_terrain``, then ``add_character``);
  ``trial``: one walk on its own client (tests, bench); ``metrics``; ``bench`` (``jostle bench quadruped``); ``config``: ``QuadrupedSpec``.
Nothing is imported here, so ``import sim.quadruped`` stays cheap.
"""
