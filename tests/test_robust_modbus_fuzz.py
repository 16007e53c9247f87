"""Protocol 0 is standard Modbus TCP on the command port at every firmware (manual 2.1.2): random
protocol-0 frames (any unit, function codes 0-255, empty and short PDUs, lengths their function's
layout disagrees with), interleaved with private frames on the same connections, get a Modbus
reply with their transaction id and unit, or a clean close; never a private-protocol reply. Each
connection sends its bytes and then closes its sending side, as a client that has said all it will."""

from __future__ import annotations

import random
import selectors
import socket
import struct
import time

import pytest

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.frame import encode_request
from xarm_emu.protocol.modbus import screen
from xarm_emu.server.app import ServerConfig, ServerThread

FRAMES = 10_000
PER_CONNECTION = 40


def _modbus_frame(rng: random.Random, tid: int) -> tuple[bytes, int]:
    unit = rng.randrange(256)
    shape = rng.random()
    if shape < 0.1:
        pdu = b""  # no function code
    elif shape < 0.3:
        pdu = bytes((rng.randrange(256),))  # a function code alone
    else:
        fc = rng.choice([1, 2, 3, 4, 5, 6, 15, 16, 22, 23, rng.randrange(256)])
        pdu = bytes((fc,)) + rng.randbytes(rng.choice([0, 1, 3, 4, 5, 6, 9, rng.randrange(40)]))
    length = 1 + len(pdu)
    if rng.random() < 0.15:  # a length that disagrees with the bytes that follow
        length = max(0, length + rng.choice([-3, -2, -1, 1, 2, 5, 9]))
    return struct.pack(">HHHB", tid, 0, length, unit) + pdu, unit


def _connection(rng: random.Random, first_tid: int) -> tuple[bytes, list[tuple[int, int, int]]]:
    """Bytes of one connection and its requests in order: (protocol, tid, unit or register)."""
    out, asked = [], []
    tid = first_tid
    for _ in range(PER_CONNECTION):
        frame, unit = _modbus_frame(rng, tid)
        out.append(frame)
        asked.append((0, tid, unit))
        tid += 1
        if screen(frame[7:])[2]:
            break  # the server closes after this one: the last frame of the connection
        prot = rng.choice([2, 3])
        out.append(encode_request(tid, 13, b"", prot))  # get_state
        asked.append((prot, tid, 13))
        tid += 1
        if struct.unpack_from(">H", frame, 4)[0] != len(frame) - 6:
            break  # framing now depends on the bytes that follow: the connection's last frames
    return b"".join(out), asked


def _replies(data: bytes) -> list[tuple[int, int, int]]:
    out = []
    while len(data) >= 7:
        tid, prot, length = struct.unpack_from(">HHH", data)
        out.append((prot, tid, data[6]))
        data = data[6 + length:]
    return out


@pytest.mark.parametrize("firmware", ["1.6.0", "2.0.102", "2.7.103"])
def test_random_protocol0_frames_get_modbus_answers_or_a_close(firmware: str) -> None:
    rng = random.Random(firmware)
    config = ServerConfig(host="127.0.0.1", port=0, normal_port=0, rich_port=0, develop_port=0)
    with ServerThread(Emulator(6, firmware=firmware), config) as st:
        port = st.ports["command"]
        conns: list[tuple[socket.socket, list[tuple[int, int, int]], bytearray]] = []
        sent = tid = 0
        while sent < FRAMES // 3:
            batch = []
            for _ in range(100):
                payload, asked = _connection(rng, tid & 0xFFFF)
                tid += len(asked)
                sent += sum(1 for a in asked if a[0] == 0)
                s = socket.create_connection(("127.0.0.1", port))
                s.sendall(payload)
                s.shutdown(socket.SHUT_WR)  # all it sends: the server answers what is whole, then closes
                s.setblocking(False)
                batch.append((s, asked, bytearray()))
            _read_all(batch)
            conns += batch
        modbus_answered = 0
        for s, asked, got in conns:
            s.close()
            replies = _replies(bytes(got))
            i = 0
            for reply in replies:  # each reply is to the next request answered, in order
                while i < len(asked) and (asked[i][0], asked[i][1]) != (reply[0], reply[1]):
                    i += 1
                assert i < len(asked), ("a reply to no request", reply, asked)
                assert reply == asked[i] or (reply[0] == 0 and reply[1:] == asked[i][1:])
                if reply[0] == 0:
                    modbus_answered += 1
                i += 1
        # replies with protocol 0 answer protocol-0 requests with their tid and unit (checked above),
        # private replies answer private requests; and most frames were answered at all
        assert modbus_answered > 0.5 * sent, (modbus_answered, sent)


def _read_all(conns: list[tuple[socket.socket, list[tuple[int, int, int]], bytearray]]) -> None:
    """Read every connection until it closes or stays quiet for 0.5 s."""
    sel = selectors.DefaultSelector()
    for s, _, got in conns:
        sel.register(s, selectors.EVENT_READ, (s, got))
    open_ = len(conns)
    quiet_until = time.monotonic() + 0.5
    while open_ and time.monotonic() < quiet_until:
        for key, _ in sel.select(0.05):
            s, got = key.data
            try:
                chunk = s.recv(65536)
            except BlockingIOError:
                continue
            except ConnectionResetError:
                chunk = b""
            quiet_until = time.monotonic() + 0.5
            if not chunk:
                sel.unregister(s)
                open_ -= 1
            got += chunk
    sel.close()
