"""The scene around the arm as a file declares it (``serve --scene``): :mod:`.contact`, the planes and
boxes the TCP presses into with their spring-damper and friction, which the F/T sensor feels and
force control pushes against; :mod:`.objects`, the loose objects of ``[[object]]`` tables (pure data),
which the physics world (:mod:`..physics`) runs."""
