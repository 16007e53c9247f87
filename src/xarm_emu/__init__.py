"""xarm-emu: an emulator of the UFACTORY xArm control box (xArm 5/6/7, Lite 6, UFACTORY 850, xArm 7T)
as the vendor's Developer Manual V1.6.0 describes it and as firmware 2.x answers.

Layers, each importing only those below it: :mod:`.protocol` (sans-IO wire formats), :mod:`.model`
(constant robot descriptions and their math), :mod:`.controller` (the control box, stepped by a
clock it is given), :mod:`.server` (asyncio ports), :mod:`.client`, then the faces:
:mod:`.viewer`, :mod:`.record`, :mod:`.plot`, :mod:`.replay`, :mod:`.cli` and :mod:`.testing`, and
above them all :mod:`.pytest_plugin`.
``docs/ARCHITECTURE.md`` says where everything is.
"""

from ._version import __version__

__all__ = ["__version__", "cli", "client", "controller", "model", "plot", "protocol", "record", "replay",
           "server", "testing", "viewer"]
