"""The Mitake character (Mitake et al. 2009 §4): one rigid body per character, balanced as an inverted pendulum.

Every character is a row of numpy arrays (``sim.mitake.crowd``); once per control tick the AI
(``sim.mitake.ai``), the state machine (``sim.mitake.states``) and the bounded balance controller
(``sim.mitake.balance``, ``sim.mitake.control``) run for all of them at once. Nothing is imported here.
"""
