"""The control box: pure and deterministic, advanced by ``step()`` on a fixed control period.

- :mod:`.emulator`: :class:`~.emulator.Emulator`, the box with its components, saved configuration,
  report snapshot, fault injection and checkpoints; what the server runs and tests drive.
- :mod:`.core`: :class:`~.core.Controller`: dispatch through the register table, the control step.
- :mod:`.handlers`: register handlers as plain functions, bound to codes in one table.
- :mod:`.states`: the motion state machine (states, modes, events, transition table).
- :mod:`.state`: :class:`~.state.ControllerState`, every mutable value of the controller.
- :mod:`.box_state`: :class:`~.box_state.EmulatorState`, every mutable value of the box as one
  tree (controller, settings, each component, Modbus user storage, schedule); checkpoints copy it.
- :mod:`.settings`, :mod:`.config`: settable parameters and their saved files.
- :mod:`.executor`, :mod:`.commands`, :mod:`.motion`, :mod:`.poses`: the command buffer and motion.
- :mod:`.mode_steps`: modes 4-7 and 11 of register 19 (:mod:`.velocity` control, :mod:`.online`
  trajectory planning, :mod:`.trajectory` playback), what the core runs for them each period.
- :mod:`.reduced`: reduced mode, its speed caps and joint ranges.
- :mod:`.safety`, :mod:`.faults`, :mod:`.thermal`: safety checks, the fault group, joint temperatures.
- :mod:`.identification`: load identification (register 204) as a wrist motion with progress.
- :mod:`.firmware2_report`: the fields a 2.x box's report frames carry beyond the manual's.
- :mod:`.feedback`: the queue of feedback events of firmware 2.x (registers 253/254), drained by the
  server into 0xFF frames.
- :mod:`.base`: the control period, command outcomes and the interface components plug in through.
- Components: :mod:`.io`, :mod:`.gripper`, :mod:`.vacuum`, :mod:`.lite6_gripper`; on the tool RS-485
  beside the xArm gripper, :mod:`.robotiq` (Robotiq 2F-85/2F-140) and :mod:`.bio_gripper` (BIO
  gripper, second generation; :mod:`.bio_gripper_g1` the first), :mod:`.inspire_hand` (Inspire
  RH56 hand); :mod:`.linear_track` (the linear track on the control box RS-485), :mod:`.ft_sensor`
  (the six-axis F/T sensor) with :mod:`.contact` (the contact scene) and :mod:`.force_control` (its
  admittance and force control, register 202); :mod:`.modbus_map` binds the standard Modbus map to a
  live box; :mod:`.physics` (objects, grasps and contacts of a scene with ``[[object]]`` tables).
"""

__all__ = ["base", "bio_gripper", "bio_gripper_g1", "box_state", "commands", "config",
           "contact", "core", "emulator", "executor", "faults", "feedback", "firmware2_report",
           "force_control", "ft_sensor", "gripper", "handlers", "identification",
           "inspire_hand", "io", "linear_track", "lite6_gripper", "modbus_map", "mode_steps",
           "motion", "online", "physics", "poses", "reduced", "robotiq", "safety", "settings",
           "state", "states", "thermal", "trajectory", "vacuum", "velocity"]
