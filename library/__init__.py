"""The motion-library file format: channel names, errors, writer and reader (numpy + h5py only)."""
