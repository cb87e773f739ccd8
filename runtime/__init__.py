"""Runtime loader for motion libraries: numpy and h5py only, for the robot's onboard computer."""
