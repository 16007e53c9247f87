"""Fidelity measured on real arms: a recording made through ``xarm-emu proxy`` replayed into the emulator
(``compare.py``), the emulator's estimated constants fitted to it (``calibrate.py``), and their commands
(``commands.py``)."""
