"""The emulator's network side (manual chapter 2): ``core`` (EmulatorServer, control loop),
``command_port`` (2.1.2) with ``fairness`` (back-pressure, round-robin, connection bounds),
``report_ports`` (2.1.6) with ``report_sender`` (one thread per process writing every frame on
its deadline), ``admin`` (requests on an AdminTarget, a table of commands with ``admin_args``, their
argument schemas)
over ``admin_port`` (socket),
``faults`` (schedules), ``thread`` (ServerThread), ``fleet``, ``workers`` (a fleet in supervised
worker processes), ``trace``, ``disk`` (the worker that
writes saves and traces off the loop), ``logs``, ``clock``, ``modbus_port`` (the Modbus map on a port
of its own), ``studio`` (the SDK's Studio HTTP calls); ``app`` gathers the names users import.
Nothing here imports the viewer, the CLI or the client: the composers above (``xarm-emu serve``,
``xarm_emu.testing``) wire those. ``proxy`` is ``xarm-emu proxy``, a transparent recording relay
to a real box, and ``xrec`` its versioned recording format; ``placement`` the control periods a
recorded request can have taken effect at, and the one way replay and compare run a stepped box to them.
"""

__all__ = ["admin", "admin_args", "admin_port", "app", "clock", "command_port", "core", "disk", "fairness",
           "faults", "fleet", "logs", "modbus_port", "placement", "proxy", "report_ports", "report_sender",
           "studio", "thread", "trace", "workers", "xrec"]
