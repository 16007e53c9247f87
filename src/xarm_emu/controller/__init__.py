"""The control box: pure and deterministic, advanced by ``step()`` on a fixed control period.

Its rooms, by subject:

- :mod:`.emulator`: :class:`~.emulator.Emulator`, the box with its components, saved configuration,
  report snapshot, fault injection and checkpoints; what the server runs and tests drive.
- :mod:`.controller`: :class:`~.controller.Controller`: dispatch through the register table, the
  control step.
- :mod:`.box_state`: :class:`~.box_state.EmulatorState`, every mutable value of the box as one
  tree (controller, settings, each component, Modbus user storage, schedule); checkpoints copy it.
- :mod:`.firmware2_report`: the fields a 2.x box's report frames carry beyond the manual's.
- :mod:`.modbus_map`: the standard Modbus map bound to a live box.
- :mod:`.core`: what everything else stands on: the control period, command outcomes and the
  interface components plug in through, the device interface every device implements; the motion
  state machine; the controller's mutable state;
  the fault group; settings and their saved files; the command buffer, poses and the executor;
  safety checks; the feedback queue of firmware 2.x; the joints' thermal model.
- :mod:`.handlers`: register handlers as plain functions, bound to codes in one table.
- :mod:`.devices`: the IO of box and tool, the end tools (xArm, vacuum, Lite 6, Robotiq, BIO G2 and
  G1 grippers, Inspire hand), the linear track and the six-axis F/T sensor.
- :mod:`.applications`: admittance and force control, velocity control, online planning,
  trajectories, reduced mode, load identification, and the modes of register 19 beyond the manual's.
- :mod:`.motion`: trajectory generation, pure math.
- :mod:`.scene`: the scene as its file declares it: contact planes and boxes, loose objects.
- :mod:`.physics`: the physics world of a scene with ``[[object]]`` tables.
"""

__all__ = ["applications", "box_state", "controller", "core", "devices", "emulator",
           "firmware2_report", "handlers", "modbus_map", "motion", "physics", "scene"]
