"""Fidelity measured on real arms: a recording made through ``xarm-emu proxy`` replayed into the emulator
(``compare.py``) and the emulator's estimated constants fitted to it (``calibrate.py``); their commands
are in :mod:`xarm_emu.cli.fidelity`."""
