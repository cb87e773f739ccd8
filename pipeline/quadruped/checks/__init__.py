"""The quadruped's independent physics checks of a solved trajectory, and the chain continuity of
a library."""
