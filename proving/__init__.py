"""The proving ground: the robot side's controller (:mod:`skatelib.control`) ridden against plants.
The model plant (a single rigid body and a rolling board, with model errors), the loops that tick
the controller at its rates, the verdicts, traces, chained rides and the steering maneuver
(:mod:`skatelib.proving.loop`, ``track``, ``ride``, ``steer``), and the same on the MuJoCo twin of
:mod:`skatelib.sim` (:mod:`skatelib.proving.twin`). Imports ``skatelib.control``, ``skatelib.sim``,
``skatelib.runtime`` and ``skatelib.library``, never ``skatelib.pipeline``; the controller never
imports it."""
