"""``python -m xarm_emu.cli``: the same as the ``xarm-emu`` command."""

from . import main

main()
