"""Facts of the controller that have one home: hosts, states, gripper codes, error-code names."""

from __future__ import annotations

import ast
import inspect
from types import ModuleType

import pytest

from xarm_emu.controller.core import interface as base
from xarm_emu.controller.core import state_machine as states
from xarm_emu.controller.devices import gripper, io
from xarm_emu.protocol import codes, rtu


def _assigned(module: ModuleType) -> set[str]:
    """The names a module binds at its top level by assignment (not by import)."""
    names: set[str] = set()
    for node in ast.parse(inspect.getsource(module)).body:
        targets = node.targets if isinstance(node, ast.Assign) else (
            [node.target] if isinstance(node, ast.AnnAssign) else [])
        names |= {t.id for t in targets if isinstance(t, ast.Name)}
    return names


def test_rs485_hosts_live_in_the_rtu_module() -> None:
    """The hosts are imported from the RTU module, never written again (an ``is`` check could not
    tell: small ints are one object whichever module defines them)."""
    assert {"TOOL_HOST", "CONTROL_BOX_HOST"} <= _assigned(rtu)
    for module in (io, gripper):
        assert not {"TOOL_HOST", "CONTROL_BOX_HOST"} & _assigned(module)
        assert (module.TOOL_HOST, module.CONTROL_BOX_HOST) == (rtu.TOOL_HOST, rtu.CONTROL_BOX_HOST)


def test_io_stop_state_is_the_state_machines() -> None:
    assert "STATE_STOP" in _assigned(states) and "STATE_STOP" not in _assigned(io)
    assert io.STATE_STOP == states.STATE_STOP


def test_gripper_error_set_is_the_code_tables() -> None:
    assert gripper.GRIPPER_ERRORS == frozenset(codes.GRIPPER_ERRORS)
    named = {getattr(gripper, n) for n in dir(gripper) if n.startswith("G_")}
    assert named <= gripper.GRIPPER_ERRORS


#: A word of the manual's name (section 3.2) that each constant's name stands for.
NAME_WORDS = {
    "C_ESTOP": "emergency stop", "C_SERVO_BASE": "servo", "C_KINEMATIC": "kinematics",
    "C_SELF_COLLISION": "self-collision", "C_JOINT_LIMIT": "joint", "C_SPEED": "speed",
    "C_PLANNING": "planning", "C_END_MODULE": "end module", "C_OTHER": "other",
    "C_COLLISION": "collision", "C_CIRCLE": "circle", "C_BOUNDARY": "boundary",
    "C_DELAYED_IO": "delayed io", "WARN_BUFFER_OVERFLOW": "buffer overflow",
    "WARN_PARAMETER": "parameter", "WARN_UNKNOWN_COMMAND": "unknown command",
    "WARN_NO_SOLUTION": "no solution",
}


def test_every_code_name_is_covered() -> None:
    assert {n for n in dir(base) if n.startswith(("C_", "WARN_"))} == set(NAME_WORDS)


@pytest.mark.parametrize("name", sorted(NAME_WORDS))
def test_code_names_agree_with_the_code_texts(name: str) -> None:
    code = getattr(base, name)
    entry = codes.controller_error(code) if name.startswith("C_") else codes.WARNINGS.get(code)
    assert entry is not None, f"{name} = {code} has no text in protocol/codes.py"
    assert NAME_WORDS[name] in entry.name.lower()
