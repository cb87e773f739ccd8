"""The controller ridden on the MuJoCo twin (:mod:`skatelib.sim`): the full-physics loop, its
sensors, measures, verdict and record, the steering maneuver, the jobs of ``track --plant mujoco``
and its chained rides."""
