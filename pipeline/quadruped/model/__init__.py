"""The quadruped's model: the robot, the board and their dynamics (Eq. 3-14), the push schedule
and the riding stance."""
