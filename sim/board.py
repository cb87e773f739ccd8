"""The skateboard from real joints: the deck a free body; per truck a hanger on a hinge about the
pivot axis through the axle's centre, with the torsional spring and damper that give the deck the
optimizer's roll stiffness and damping; per hanger two wheels on hinges, rolling on the floor with
a rolling resistance proportional to their load (a torque on each wheel's hinge,
:mod:`skatelib.sim.rolling`).

Geometry (deck frame: origin on the deck's top surface at its centre, x forward, z up): the axles
lie ``axle_below_deck_m`` under the top at x = +l_front and -l_rear; each pivot axis rises from the
axle towards its end of the deck (the pivot cup sits outboard of the kingpin) at
``pivot_from_horizontal_rad`` from the ground, so that a deck rolled to the right turns the board
to the right. A deck roll phi
with the wheels on the ground turns each hanger by phi / cos(lambda) about its axis and steers it
by tan(delta) = sin(phi) tan(lambda); a hinge spring k = K_B cos(lambda)^2 / 2 per truck then holds
the deck with K_B.
"""

from __future__ import annotations

import math
from typing import Any

from skatelib.sim.figures import DECK_THICKNESS_M, HANGER_MASS_KG, BoardFigures
from skatelib.sim.rolling import add_rolling_actuators

# Collision bits (contype / conaffinity): the floor touches wheels, feet, deck and robot links; the
# deck touches feet; nothing else touches anything.
FLOOR_BIT, FOOT_BIT = 1, 2
BODIES = ("deck", "truck_front", "truck_rear", "wheel_fl", "wheel_fr", "wheel_rl", "wheel_rr")  # add_board's
# Urethane wheels are stiff (a 99A wheel gives about 0.1 mm under the robot's weight): a contact
# time constant of 5 ms and a high impedance (MuJoCo's defaults let the loaded side's wheels sink
# most of a millimetre more than the light side's, a roll compliance no real wheel has).
WHEEL_SOLREF_S = 0.005
WHEEL_SOLIMP = (0.99, 0.999, 0.0005, 0.5, 2.0)


def add_board(spec: Any, b: BoardFigures, friction_mu: float, pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
              ) -> Any:
    """Add the board to ``spec``'s world with its deck's top centre at ``pos`` + deck height; returns
    the deck body. Bodies and joints are named ``deck``, ``truck_{front,rear}``, ``wheel_{fl,fr,rl,rr}``."""
    import mujoco

    deck = spec.worldbody.add_body(name="deck", pos=[pos[0], pos[1], pos[2] + b.deck_height_m])
    deck.add_freejoint(name="deck_free")
    deck.add_geom(name="deck", type=mujoco.mjtGeom.mjGEOM_BOX,
                  size=[b.deck_length_m / 2, b.deck_width_m / 2, DECK_THICKNESS_M / 2],
                  pos=[0, 0, -DECK_THICKNESS_M / 2], mass=b.deck_mass_kg, contype=0,
                  conaffinity=FLOOR_BIT | FOOT_BIT, friction=[friction_mu, 0.005, 0.0001], condim=3)
    deck.explicitinertial = True
    deck.mass = b.deck_mass_kg
    deck.ipos = [0, 0, -DECK_THICKNESS_M / 2]
    deck.inertia = list(b.deck_inertia_kgm2)
    wheel_mass = (b.mass_kg - b.deck_mass_kg - 2 * HANGER_MASS_KG) / 4  # the rest of the board's mass
    lam = b.pivot_from_horizontal_rad
    k = b.roll_stiffness_Nm_per_rad * math.cos(lam) ** 2 / 2
    c = b.roll_damping_Nms_per_rad * math.cos(lam) ** 2 / 2
    for name, x, lean in (("front", b.l_front_m, 1.0), ("rear", -b.l_rear_m, -1.0)):
        hanger = deck.add_body(name=f"truck_{name}", pos=[x, 0, -b.axle_below_deck_m])
        hanger.add_joint(name=f"truck_{name}", type=mujoco.mjtJoint.mjJNT_HINGE,
                         axis=[lean * math.cos(lam), 0, math.sin(lam)], stiffness=[k, 0, 0], damping=[c, 0, 0])
        hanger.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[0.008, b.wheel_y_m, 0],
                        fromto=[0, -b.wheel_y_m, 0, 0, b.wheel_y_m, 0], contype=0, conaffinity=0, mass=HANGER_MASS_KG,
                        rgba=[0.6, 0.6, 0.65, 1])
        for side, y in (("l", b.wheel_y_m), ("r", -b.wheel_y_m)):
            wheel = hanger.add_body(name=f"wheel_{name[0]}{side}", pos=[0, y, 0])
            wheel.add_joint(name=f"wheel_{name[0]}{side}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
            wheel.add_geom(name=f"wheel_{name[0]}{side}", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                           size=[b.wheel_radius_m, 0, 0], mass=wheel_mass, contype=0, conaffinity=FLOOR_BIT,
                           condim=3, friction=[1.0, 0.0, 0.0],
                           solref=[WHEEL_SOLREF_S, 1.0], solimp=list(WHEEL_SOLIMP), rgba=[0.9, 0.85, 0.6, 1])
    add_rolling_actuators(spec)
    return deck
