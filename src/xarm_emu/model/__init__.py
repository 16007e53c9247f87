"""Constant robot descriptions and the math over them: a model never changes (frozen dataclasses), and
the only state here is memo caches of pure functions of a model (the generated kinematics code and
joint limits in :mod:`.kinematics`, the collision layout and its pairs in :mod:`.collision`, the
dynamic chain in :mod:`.dynamics`), keyed on the model object; what they hold never changes an answer.

- :mod:`.robots`: the arms (joint frames, limits, identity, tool IO) and :func:`~.robots.get_model`.
- :mod:`.inertials`: link masses, centres of mass, inertia tensors, torque constants.
- :mod:`.rotations`: roll/pitch/yaw, axis-angle, quaternions, pose <-> 4x4 matrix (manual 1.5).
- :mod:`.kinematics`: forward and inverse kinematics, Jacobian, TCP and user offsets
  (its unrolled scalar code comes from :mod:`._unroll`).
- :mod:`.dynamics`: gravity and inverse-dynamics joint torques.
- :mod:`.collision`: self-collision geometry derived from the joint frames.
- :mod:`.calibration`: a calibration's measured constants (torque constants and offsets, friction,
  thermal), applied when a model is built; never what the manual fixes.
"""

__all__ = ["calibration", "collision", "dynamics", "inertials", "kinematics", "robots", "rotations"]
