"""The asyncio emulator server, by the names its users import.

- :class:`ServerConfig` and :class:`EmulatorServer` (ports and control loop): :mod:`.core`;
- the command port (manual 2.1.2): :mod:`.command_port`; the report ports (2.1.6): :mod:`.report_ports`;
- the admin channel: :mod:`.admin` (requests) over :mod:`.admin_port` (socket);
- :class:`ServerThread` (a server on a background thread, fault schedule wired): :mod:`.thread`.
"""

from __future__ import annotations

from .core import Attachment, EmulatorServer, ServerConfig
from .thread import ServerThread, new_event_loop

__all__ = ["Attachment", "EmulatorServer", "ServerConfig", "ServerThread", "new_event_loop"]
