"""The quadruped on the skateboard: robot (URDF), board, system, dynamics (Eq. 3-9), the push
schedule, the push-off terms and problem, its independent physics checks, library entries and
the reachable-speed frontier."""
