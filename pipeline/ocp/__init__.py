"""The robot-agnostic optimal-control engine: terms and stages (``terms``), a stage's expressions
(``expressions``), direct multiple shooting (``shooting``) over stage-wise CasADi functions
(``stagewise``, with the compiled-code cache; given Hessians in ``curvature``), one-interval
integrators, the Gauss pseudospectral method (``gpm``) and rotations. No robot in it."""
