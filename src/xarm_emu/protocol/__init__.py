"""The wire, sans-IO (bytes in, typed values out; no sockets, no clock), manual chapter 2.

- :mod:`.frame`: command-port frames (section 2.1.2), protocol ids, reply state bits.
- :mod:`.layouts`: declarative byte layouts of register parameters.
- :mod:`.registers`: the register table, the one home of every command's byte layout, by firmware.
- :mod:`.firmware`: firmware versions and profiles (what changes on the wire with the version).
- :mod:`.feedback`: the 0xFF feedback frames of firmware 2.x.
- :mod:`.reports`: the report snapshot and the report frames of ports 30000-30003 (section 2.1.6).
- :mod:`.codes`: error, warning, servo and gripper codes (chapter 3).
- :mod:`.rtu`: Modbus-RTU PDUs of the tool and control box RS-485 (section 2.1.4).
- :mod:`.regmap`: register maps of the RS-485 slaves and the one read and write function serving them.
- :mod:`.modbus`: the standard Modbus-TCP map (protocol id 0).
- :mod:`.admin`: the admin channel's JSON-lines wire.
- :mod:`.admin_token`: where the admin channel's token file is, read by server and client alike.
- :mod:`.modbus_pdu`: standard Modbus PDUs decoded for the trace (function, address, count, values,
  exception).
"""

__all__ = ["admin", "admin_token", "codes", "feedback", "firmware", "frame", "layouts", "modbus",
           "modbus_pdu", "registers", "regmap", "reports", "rtu"]
