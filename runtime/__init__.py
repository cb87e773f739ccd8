"""Runtime loader for motion libraries: numpy and h5py only, for the robot's onboard computer.

>>> from skatelib.runtime import MotionLibrary
>>> lib = MotionLibrary.open("out/cyberdog2-default.h5")   # doctest: +SKIP
>>> ref = lib.select(0.5, strides=2).sample(0.6)            # doctest: +SKIP
"""

from skatelib.runtime.blend import BlendCheck, BlendMargin
from skatelib.runtime.entry import Entry, EntryNotFound
from skatelib.runtime.motion_library import MotionLibrary
from skatelib.runtime.references import Channels, Sample, Window

__all__ = ["BlendCheck", "BlendMargin", "Channels", "Entry", "EntryNotFound", "MotionLibrary", "Sample", "Window"]
