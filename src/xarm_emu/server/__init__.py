"""xarm-emu."""
