"""Every register with random parameters (bad input): the controller answers each with
a well-formed reply and a clear warning or state, never an unexpected exception, and keeps
stepping. ``strict`` makes any unexpected exception fail the test instead of being logged."""

from __future__ import annotations

import os
import struct

import pytest
from helpers import call, ready
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from xarm_emu.controller.emulator import Emulator
from xarm_emu.protocol.registers import REGISTERS

CODES = sorted(REGISTERS)
# `make fuzz` multiplies the example count to explore further than `make test` does.
SCALE = max(1, int(os.environ.get("XARM_EMU_FUZZ_SCALE", "1")))


def accepted_sizes(code: int) -> list[int]:
    layout = REGISTERS[code].request
    options = getattr(layout, "options", None)
    sizes = [n for opt in options for n in opt.sizes()] if options else layout.sizes()
    if layout.rest is not None or (options and any(o.rest is not None for o in options)):
        sizes += [layout.size + 1, layout.size + 8]
    return sorted(set(sizes))


@st.composite
def requests(draw: st.DrawFn) -> tuple[int, bytes]:
    code = draw(st.sampled_from(CODES))
    size = draw(st.sampled_from(accepted_sizes(code)))
    if draw(st.booleans()):
        # floats that decode to plausible numbers, including NaN/inf and extremes
        floats = draw(st.lists(st.sampled_from([0.0, 1.0, -1.0, 0.5, 3.1416, 100.0, 1e9, -1e9,
                                                3.0e38, -3.0e38, 1e-40, float("nan"),
                                                float("inf")]), min_size=size // 4,
                               max_size=size // 4))
        raw = struct.pack(f"<{len(floats)}f", *floats) + draw(st.binary(min_size=size % 4, max_size=size % 4))
    else:
        raw = draw(st.binary(min_size=size, max_size=size))
    return code, raw


@settings(max_examples=400 * SCALE, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(reqs=st.lists(requests(), min_size=1, max_size=12), enabled=st.booleans(),
       dof=st.sampled_from([6, 5, 7]))
def test_random_requests_never_raise(reqs: list[tuple[int, bytes]], enabled: bool, dof: int) -> None:
    emu = Emulator(dof)
    emu.controller.strict = True
    if enabled:
        ready(emu)
    for code, raw in reqs:
        if code in (10, 39, 40):  # shutdown / configuration files: covered elsewhere
            continue
        state, reply = emu.handle(code, raw)
        assert 0 <= state <= 0xFF
        reg = REGISTERS[code]
        if reply:
            assert reg.reply.accepts(len(reply)), (code, len(reply))
        emu.step(5)
    emu.advance(0.5)
    assert call(emu, 13)[1]["state"] in (1, 2, 3, 4, 5)


@pytest.mark.parametrize("code", CODES)
def test_wrong_length_of_every_register_is_warning_12(code: int) -> None:
    emu = Emulator(6)
    emu.controller.strict = True
    sizes = accepted_sizes(code)
    bad = next(n for n in range(0, 80) if n not in sizes and not REGISTERS[code].request.accepts(n))
    state, _ = emu.handle(code, bytes(bad))
    assert state & 0x20
    assert call(emu, 15)[1]["warning"] == 12


# Left out of the sweep: register 10 (system control) shuts the box down or reboots it, and
# registers 39/40 remove or write the saved configuration files; test_controller_config.py and the
# server tests cover them with a configuration directory of their own.
SWEPT = [code for code in CODES if code not in (10, 39, 40)]


@pytest.mark.parametrize("code", SWEPT)
def test_every_accepted_size_of_every_register_with_random_values(code: int) -> None:
    """Deterministic sweep: each accepted parameter size, 20 random payloads, from a ready arm. Each
    reply has a size the register's reply layout accepts, the warning bit (0x20) is set exactly
    when the controller holds a warning code (register 15), and the arm still reports a state."""
    import random

    rng = random.Random(code)
    specials = [0.0, -0.0, 1.0, -1.0, 3.1416, 1e9, -1e9, float("nan"), float("inf"), 8.0, 21.0, 22.0]
    for size in accepted_sizes(code):
        for k in range(20):
            emu = Emulator(6)
            emu.controller.strict = True
            ready(emu)
            if k % 2:
                floats = [rng.choice(specials) for _ in range(size // 4)]
                tail = bytes(rng.randrange(256) for _ in range(size % 4))
                raw = struct.pack(f"<{len(floats)}f", *floats) + tail
            else:
                raw = bytes(rng.randrange(256) for _ in range(size))
            state, reply = emu.handle(code, raw)
            assert REGISTERS[code].reply.accepts(len(reply)), (code, size, raw)
            warning = call(emu, 15)[1]["warning"]
            assert bool(state & 0x20) == (warning != 0), (code, size, raw, state, warning)
            emu.step(3)
            assert call(emu, 13)[1]["state"] in (1, 2, 3, 4, 5), (code, size, raw)
