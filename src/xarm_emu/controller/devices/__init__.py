"""The devices the control box talks to: the IO of the box and the tool, the end tools (xArm gripper,
vacuum and Lite 6 grippers; Robotiq, BIO and Inspire on the tool RS-485), the linear track on the
box's RS-485 and the six-axis F/T sensor. Each is a component: its own registers and its own state.
"""
