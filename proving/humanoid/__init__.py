"""The humanoid's proving ground: its motions executed on the twin under the stabilizer, and their verdict."""
