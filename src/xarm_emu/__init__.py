"""xarm-emu: an emulator of the UFACTORY xArm 5/6/7 control box (Developer Manual V1.6.0)."""

__version__ = "0.1.0"
