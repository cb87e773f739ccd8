"""Building a library, whatever the robot kind: the sweep of its tasks, the entry cache, the checks
before work and the provenance written into the file."""
