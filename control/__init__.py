"""The robot side's reference controller: the paper's linear MPC (Sec. V-B, Eq. 17-19) fed by
:mod:`skatelib.runtime`, and the closed-loop simulation that tests a library entry against a
nonlinear plant with model error. Imports ``skatelib.runtime`` and ``skatelib.library`` (and its
QP solvers), never ``skatelib.pipeline``."""
