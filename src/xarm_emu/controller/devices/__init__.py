"""The devices the control box talks to: the IO of the box and the tool, the end tools (xArm gripper,
vacuum and Lite 6 grippers; Robotiq, BIO G2 and G1 and Inspire on the tool RS-485), the linear track on
the box's RS-485 and the six-axis F/T sensor. Each is a device of ``controller/core/device.py``: its own
registers (``REGISTER_MAP``), its own state, one ``step(dt, ctl)``, its errors and what the status
shows of it.
"""
