"""What the twin's feet touch, read from MuJoCo's contact arrays: each foot's touch code (the deck
or the floor), contact point and normal load, and the geoms other than feet and wheels that touch
the floor (a knee, the trunk: what a verdict calls a fall or an unplanned contact)."""

from __future__ import annotations

from typing import Any

import numpy as np

NO_CONTACT, ON_DECK, ON_FLOOR = 0, 1, 2


def stray_on_floor(g1: np.ndarray, g2: np.ndarray, floor: int, planned: np.ndarray) -> set[int]:
    """The geoms (ids) of the contacts ``g1``, ``g2`` (MuJoCo's contact arrays) that touch the
    ``floor`` and are not ``planned`` there (``planned``: a flag per geom of the model)."""
    other = np.where(g1 == floor, g2, g1)
    return set(other[((g1 == floor) | (g2 == floor)) & ~planned[other]].tolist())


class FootContacts:
    """The contact tables of a compiled twin: each geom's foot, and the geoms planned on the floor."""

    def __init__(self, m: Any, feet: np.ndarray, wheels: np.ndarray, floor: int, deck: int):
        self.m, self.floor, self.deck = m, floor, deck
        self.foot_of = np.full(m.ngeom, -1)  # each geom's foot (-1: none)
        self.foot_of[feet] = np.arange(len(feet))
        self.planned = np.zeros(m.ngeom, dtype=bool)  # a foot or a wheel: its place is on the floor
        self.planned[np.concatenate([feet, wheels])] = True
        self._force = np.zeros(6)

    def read(self, d: Any, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, set[str]]:
        """Each foot's touch code (4,) and load (4,) [N], its contact point written into ``points``
        (3, 4) where it touches (a foot's last contact), and the names of the other geoms on the floor.
        The contacts are picked from the arrays: a Python loop over every contact of a robot on a
        board costs as much as a physics step."""
        import mujoco

        touch, loads = np.zeros(4, dtype=np.int8), np.zeros(4)
        if d.ncon == 0:
            return touch, loads, set()
        m, con = self.m, d.contact
        g1, g2 = con.geom1, con.geom2
        f1, f2 = self.foot_of[g1], self.foot_of[g2]
        on_deck = (g1 == self.deck) | (g2 == self.deck)
        pos = con.pos
        for k in np.nonzero((f1 >= 0) | (f2 >= 0))[0]:
            mujoco.mj_contactForce(m, d, int(k), self._force)
            a, b = int(f1[k]), int(f2[k])
            for i in (a, b) if a < b else (b, a) if b < a else (a,):  # a foot on a foot: both, in order
                if i < 0:
                    continue
                touch[i] = ON_DECK if on_deck[k] else ON_FLOOR
                points[:, i] = pos[k]
                loads[i] += self._force[0]
        return touch, loads, {self.name(g) for g in stray_on_floor(g1, g2, self.floor, self.planned)}

    def stray(self, d: Any) -> set[int]:
        """The geoms other than feet and wheels on the floor (ids)."""
        if d.ncon == 0:
            return set()
        return stray_on_floor(d.contact.geom1, d.contact.geom2, self.floor, self.planned)

    def name(self, g: int) -> str:
        """Geom ``g``'s name, or which body's it is."""
        m = self.m
        return m.geom(g).name or f"geom {g} of body {m.body(m.geom_bodyid[g]).name}"
