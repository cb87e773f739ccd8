"""The robustness certificate (``skatelib certify``): each entry ridden on the twin under model
errors and a shove drawn from the config's ``[certify]`` distributions (:mod:`.spec`, :mod:`.draw`),
each ride judged as ``track --plant mujoco`` judges it (:mod:`.ride`), and per entry the success
rate with its 95 % Wilson interval, the failure modes and the shove margin (:mod:`.stats`)."""
