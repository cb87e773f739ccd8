"""The robot-agnostic optimal-control engine: terms and stages (``terms``), direct multiple
shooting (``shooting``) over stage-wise CasADi functions (``stagewise``, with the compiled-code
cache), one-interval integrators, the Gauss pseudospectral method (``gpm``) and rotations. No
robot in it."""
