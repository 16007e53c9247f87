"""Every request/response example of manual section 2.1.4, through the register table and the
peripheral components (frames built and parsed with protocol/frame.py).

Manual errata handled here, each asserted explicitly:
- register 124 and the 127 baud-rate responses omit the reply state byte (their length fields
  count no state byte); the SDK needs it, so our frame is the manual's with a 0x00 state byte
  after the register and the length one larger;
- "Set the gripper mode" answers with address 0x0100 for a write to 0x0101 (copy error);
- "Get the gripper position" shows function 0x10 with no byte count (a malformed write);
- "Get GPIO state" shows a digital-input function word 0x0100 with no input function set.
"""

from __future__ import annotations

import pytest
from helpers import ready

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol import rtu
from xarm_emu.protocol.frame import decode_reply, decode_request, encode_reply
from xarm_emu.protocol.registers import REGISTERS


def h(text: str) -> bytes:
    return bytes.fromhex(text.replace(",", " ").replace("0x", ""))


class Box:
    """The manual's request frames through the real emulator (``Emulator.handle``): frame in, frame
    out. ``io`` and ``grip`` are the emulator's IO and gripper modules, for setting up and reading
    back the state the examples show. The arm has run the start sequence, so the state byte of a
    reply carries no "not ready" bit (0x10) and matches the manual's 0x00."""

    def __init__(self, n_digital: int = 16) -> None:
        # Control boxes before AC1300 have 8 digital IO (manual section 2.1.4, register 139).
        self.emu = Emulator(6, box_sn="AC1300" if n_digital == 16 else "AC1200")
        ready(self.emu)
        self.io = self.emu.io
        self.grip = self.emu.gripper

    def __call__(self, frame: bytes) -> bytes:
        req = decode_request(frame)
        state, out = self.emu.handle(req.register, req.params)
        return encode_reply(req.tid, req.protocol, req.register, state, out)


def with_state_byte(manual_reply: bytes) -> bytes:
    """The manual's 124/127-baud reply with the (omitted) state byte 0x00 put back."""
    length = int.from_bytes(manual_reply[4:6], "big")
    return manual_reply[:4] + (length + 1).to_bytes(2, "big") + manual_reply[6:7] + b"\x00" + manual_reply[7:]


# (title, request, manual response) for register 124 examples that need only the state-byte fix.
GRIPPER_WRITES = [
    ("enable", "00 01 00 02 00 0B 7C 09 08 10 01 00 00 01 02 00 01",
     "00 01 00 02 00 08 7C 09 08 10 01 00 00 01"),
    ("speed 1500", "00 01 00 02 00 0B 7C 09 08 10 03 03 00 01 02 05 DC",
     "00 01 00 02 00 08 7C 09 08 10 03 03 00 01"),
    ("position", "00 01 00 02 00 0D 7C 09 08 10 07 00 00 02 04 00 00 C8 43",
     "00 01 00 02 00 08 7C 09 08 10 07 00 00 02"),
    ("get error", "00 01 00 02 00 08 7C 09 08 03 00 0F 00 01",
     "00 01 00 02 00 07 7C 09 08 03 02 00 00"),
    ("clear error", "00 01 00 02 00 0B 7C 09 08 10 01 09 00 01 02 00 01",
     "00 01 00 02 00 08 7C 09 08 10 01 09 00 01"),
]


@pytest.mark.parametrize("title,request_hex,reply_hex", GRIPPER_WRITES, ids=[g[0] for g in GRIPPER_WRITES])
def test_gripper_examples(title: str, request_hex: str, reply_hex: str) -> None:
    box = Box()
    if title == "get error":
        box.grip.gripper.error = 0
    req = h(request_hex)
    values = REGISTERS[124].request.decode(decode_request(req).params)
    assert values["host"] == 9 and values["rtu"] == req[8:]
    assert REGISTERS[124].request.encode(values) == req[7:]  # encodes back byte for byte
    got = box(req)
    assert got == with_state_byte(h(reply_hex))
    rep = decode_reply(got)
    assert REGISTERS[124].reply.encode(REGISTERS[124].reply.decode(rep.params)) == rep.params


def test_gripper_example_effects() -> None:
    box = Box()
    box(h("00 01 00 02 00 0B 7C 09 08 10 01 00 00 01 02 00 01"))
    assert box.grip.gripper.enabled
    box(h("00 01 00 02 00 0B 7C 09 08 10 03 03 00 01 02 05 DC"))
    assert box.grip.gripper.speed == 1500
    # The manual's position bytes are fp32 400.0; as the s32 the SDK sends they are 51267: G25.
    box(h("00 01 00 02 00 0D 7C 09 08 10 07 00 00 02 04 00 00 C8 43"))
    assert box.grip.gripper.error == 0x19
    got = box(h("00 01 00 02 00 08 7C 09 08 03 00 0F 00 01"))
    assert got == with_state_byte(h("00 01 00 02 00 07 7C 09 08 03 02 00 19"))
    box(h("00 01 00 02 00 0B 7C 09 08 10 01 09 00 01 02 00 01"))
    assert box.grip.gripper.error == 0


def test_gripper_mode_example_erratum() -> None:
    box = Box()
    got = box(h("00 01 00 02 00 0B 7C 09 08 10 01 01 00 01 02 00 00"))
    manual = with_state_byte(h("00 01 00 02 00 08 7C 09 08 10 01 00 00 01"))
    assert len(got) == len(manual)
    diff = [i for i in range(len(got)) if got[i] != manual[i]]
    assert diff == [12] and got[12] == 0x01 and manual[12] == 0x00  # only the echoed address low byte
    assert box.grip.gripper.mode == 0


def test_gripper_get_position_example_erratum() -> None:
    box = Box()
    req = h("00 01 00 02 00 08 7C 09 08 10 07 02 00 02")
    assert REGISTERS[124].request.decode(decode_request(req).params) == {"host": 9, "rtu": req[8:]}
    # As printed it is a write without byte count: a Modbus exception (illegal data value).
    assert decode_reply(box(req)).params == h("09 08 90 03")
    # The read the SDK sends instead answers with the position, s32 big-endian.
    box.grip.gripper.position = 400.0
    rep = decode_reply(box(h("00 01 00 02 00 08 7C 09 08 03 07 02 00 02")))
    assert rep.params == h("09 08 03 04 00 00 01 90")


def test_baud_example() -> None:
    box = Box()
    box.io.tool.baud_index[9] = 5
    req = h("00 01 00 02 00 08 7F 09 1A 0B 00 00 30 41")
    values = REGISTERS[127].request.decode(decode_request(req).params)
    assert values == {"host": 9, "addr": 0x1A0B, "value": 11.0}
    assert REGISTERS[127].request.encode(values) == req[7:]
    assert box(req) == with_state_byte(h("00 01 00 02 00 01 7F"))
    assert box.io.tool.baud_index[9] == 11


IO_EXAMPLES = [
    ("tool DO open 0", "00 01 00 02 00 08 7F 09 0A 15 00 80 80 43", "00 01 00 02 00 02 7F 00"),
    ("tool DI", "00 01 00 02 00 04 80 09 0A 14", "00 01 00 02 00 06 80 00 00 00 00 00"),
    ("tool AI0", "00 01 00 02 00 04 80 09 0A 16", "00 01 00 02 00 06 80 00 00 00 07 0D"),
    ("cgpio DI", "00 01 00 02 00 01 83", "00 01 00 02 00 04 83 00 FF FD"),
    ("AI1", "00 01 00 02 00 01 84", "00 01 00 02 00 04 84 00 00 12"),
    ("AI2", "00 01 00 02 00 01 85", "00 01 00 02 00 04 85 00 00 15"),
    ("CO7 low", "00 01 00 02 00 03 86 80 00", "00 01 00 02 00 02 86 00"),
    ("AO1", "00 01 00 02 00 03 87 00 00", "00 01 00 02 00 02 87 00"),
    ("AO2", "00 01 00 02 00 03 88 00 00", "00 01 00 02 00 02 88 00"),
    ("CO7 function", "00 01 00 02 00 03 8A 07 00", "00 01 00 02 00 02 8A 00"),
    ("delayed cgpio", "00 01 00 02 00 07 8E 00 01 00 00 40 40", "00 01 00 02 00 02 8E 00"),
    ("delayed tgpio", "00 01 00 02 00 07 8F 00 01 00 00 40 40", "00 01 00 02 00 02 8F 00"),
    ("position cgpio",
     "00 01 00 02 00 13 90 00 01 00 00 C8 43 00 00 00 00 00 00 48 43 00 00 48 42", "00 01 00 02 00 02 90 00"),
    ("position tgpio",
     "00 01 00 02 00 13 91 00 01 00 00 C8 43 00 00 00 00 00 00 48 43 00 00 48 42", "00 01 00 02 00 02 91 00"),
    ("stop reset", "00 01 00 02 00 03 92 00 01", "00 01 00 02 00 04 92 00 00 01"),
    ("position analog",
     "00 01 00 02 00 14 93 00 00 00 00 00 C8 43 00 00 00 00 00 00 48 43 00 00 48 42",
     "00 01 00 02 00 02 93 00"),
]


@pytest.mark.parametrize("title,request_hex,reply_hex", IO_EXAMPLES, ids=[e[0] for e in IO_EXAMPLES])
def test_io_examples(title: str, request_hex: str, reply_hex: str) -> None:
    box = Box()
    # The sensor values the examples show.
    box.emu.set_input("tool-analog", 0, 1805 * 3.3 / 4095)
    box.emu.set_input("cgpio", 1, 0)
    box.emu.set_input("analog", 0, 18 * 10 / 4095)
    box.emu.set_input("analog", 1, 21 * 10 / 4095)
    req = h(request_hex)
    reg = REGISTERS[req[6]]
    params = decode_request(req).params
    assert reg.request.encode(reg.request.decode(params)) == params
    assert box(req) == h(reply_hex)


def test_io_example_effects() -> None:
    box = Box()
    box(h("00 01 00 02 00 08 7F 09 0A 15 00 80 80 43"))  # 257.0: open 0
    assert box.io.tool.output(0) == 1 and box.io.tool.output(1) == 0
    box.io.cgpio.set_output(7, 1)
    box(h("00 01 00 02 00 03 86 80 00"))  # GPIO7 low
    assert box.io.cgpio.output(7) == 0
    box(h("00 01 00 02 00 03 8A 07 00"))
    assert box.io.cgpio.output_functions[7] == 0
    box(h("00 01 00 02 00 07 8E 00 01 00 00 40 40"))
    assert box.io.pending[-1].due == pytest.approx(3.0)
    box(h("00 01 00 02 00 03 92 00 01"))
    assert box.io.cgpio_reset_on_stop and not box.io.tgpio_reset_on_stop
    box(h("00 01 00 02 00 14 93 00 00 00 00 00 C8 43 00 00 00 00 00 00 48 43 00 00 48 42"))
    p = box.io.pending[-1]
    assert (p.target, p.index, p.value, p.center, p.radius) == ("analog", 0, 0, (400.0, 0.0, 200.0), 50.0)


def test_gpio_state_example() -> None:
    manual = h("00 01 00 02 00 24 8B 00  00 00  01 00  FF FD  00 00  FF 00  00 11  00 15  00 00  00 00"
               + " 00" * 16)
    box = Box(n_digital=8)
    box.emu.set_input("cgpio", 1, 0)
    box.emu.set_input("analog", 0, 0x11 * 10 / 4095)
    box.emu.set_input("analog", 1, 0x15 * 10 / 4095)
    for i in range(8):  # the example's configuration: every function number 0
        box.io.cgpio.set_function(False, i, 0)
        box.io.cgpio.set_function(True, i, 0)  # 0 = "system in STOP state"; the arm is not stopped
    box.emu.step(1)  # one control period: the outputs follow their functions
    got = box(h("00 01 00 02 00 01 8B"))
    assert len(got) == len(manual) == 6 + 36
    reply = REGISTERS[139].reply
    ours, theirs = reply.decode(decode_reply(got).params), reply.decode(decode_reply(manual).params)
    assert reply.encode(theirs) == manual[8:]
    theirs_di_function = theirs.pop("di_function")
    assert theirs_di_function == 0x0100 and ours.pop("di_function") == 0
    assert ours == theirs


def test_gpio_state_16_io_is_50_bytes() -> None:
    box = Box(n_digital=16)
    box.io.cgpio.set_function(True, 12, 2)
    rep = decode_reply(box(h("00 01 00 02 00 01 8B")))
    assert len(rep.params) == 50
    assert rep.params[34 + 8 + 4] == 2 and rep.params[34:42] == b"\xff" * 8


def test_rtu_reply_parses() -> None:
    box = Box()
    rep = decode_reply(box(h("00 01 00 02 00 08 7C 09 08 03 08 01 00 03")))
    assert rtu.parse_reply(rep.params[1:]) == (8, 3, box.grip.gripper.version)
