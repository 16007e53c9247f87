"""One device interface (controller/core/device.py): every module of controller/devices/ implements it,
the emulator plugs every device the same way and holds no ``isinstance`` test of a device class."""

from __future__ import annotations

import ast
import functools
import inspect
import pkgutil
from collections.abc import Mapping
from pathlib import Path

import pytest
from helpers import FakeView

from xarm_emu.controller import devices
from xarm_emu.controller.core.device import Device
from xarm_emu.controller.devices.gripper import GripperModule
from xarm_emu.controller.devices.io import ADDR_TOOL_DI, ADDR_TOOL_DO, ADDR_TOOL_DO_READ, IOModule
from xarm_emu.controller.emulator import GRIPPERS, Emulator
from xarm_emu.protocol import regmap

EMULATOR = Path(__file__).resolve().parents[1] / "src" / "xarm_emu" / "controller" / "emulator.py"
#: What each device's error interface takes (a device without an error code of its own refuses).
ERRORS = {"RobotiqGripper": 5, "BioGripper": 11, "BioGripperG1": 11, "InspireHand": 3, "XArmGripper": 0x0C,
          "GripperModule": 0x0C, "LinearTrack": 11, "FtSensorComponent": 3}


@functools.cache
def every_device() -> list[Device]:
    """Every device of every kind, plugged in as the emulator plugs them (built on first use)."""
    out: list[Device] = []
    for gripper in GRIPPERS:
        emu = Emulator(6, firmware="2.7.103", gripper=gripper)
        out += emu.devices + [emu.gripper.device]
    emu = Emulator(6, firmware="2.7.103", vacuum=True, linear_track=700, ft_sensor=True)
    out += emu.devices
    out += Emulator("lite6", firmware="2.7.103").devices
    return out


def test_every_module_of_devices_implements_the_interface():
    modules = {m.name for m in pkgutil.iter_modules(devices.__path__)}
    implemented = {type(d).__module__.rsplit(".", 1)[-1] for d in every_device()}
    assert modules == implemented and {type(d).__name__ for d in every_device()} == set(NAMES)
    for d in every_device():
        assert isinstance(d, Device), type(d).__name__
        assert isinstance(type(d).REGISTER_MAP, Mapping)
        assert all(isinstance(r, regmap.Reg) for r in type(d).REGISTER_MAP.values())
        assert list(inspect.signature(d.step).parameters) == ["dt", "ctl"], type(d).__name__
        assert list(inspect.signature(d.idle_until).parameters) == ["ctl"], type(d).__name__
        assert d.data is not None and isinstance(d.status_fields(), dict)
    # the Modbus slaves have their holding registers, the IO its tool board's; the rest none of their own
    with_map = {type(d).__name__ for d in every_device() if d.REGISTER_MAP}
    assert with_map == {"XArmGripper", "RobotiqGripper", "BioGripper", "BioGripperG1", "InspireHand",
                        "LinearTrack", "IOModule"}


def test_every_device_steps_with_one_signature():
    view = FakeView()
    for d in every_device():
        if not isinstance(d, (GripperModule, IOModule)) and type(d).__name__ != "FtSensorComponent":
            d.step(0.004, view)  # a device alone needs nothing of the controller but the view


#: Every device class (test_every_module_of_devices_implements_the_interface checks the list).
NAMES = ["IOModule", "GripperModule", "XArmGripper", "RobotiqGripper", "BioGripper", "BioGripperG1",
         "InspireHand", "VacuumGripper", "Lite6Gripper", "LinearTrack", "FtSensorComponent"]


@pytest.mark.parametrize("name", NAMES)
def test_errors_through_the_interface(name: str):
    d = next(d for d in every_device() if type(d).__name__ == name)
    code = ERRORS.get(name)
    if code is None:
        with pytest.raises(ValueError, match="no error code"):
            d.inject_error(1)
        assert d.error == 0
        d.clear_error()
        return
    d.inject_error(code)
    assert d.error == code
    d.clear_error()
    assert d.error == 0


def test_the_io_boards_registers_are_its_register_map():
    io = IOModule()
    assert {ADDR_TOOL_DI, ADDR_TOOL_DO, ADDR_TOOL_DO_READ} <= set(IOModule.REGISTER_MAP)
    io.tool.write(9, ADDR_TOOL_DO, 257.0)  # "open 0": TO0 on
    assert io.tool.read(9, ADDR_TOOL_DO_READ) == 1 == regmap.read_registers(IOModule.REGISTER_MAP, io.tool,
                                                                            ADDR_TOOL_DO_READ, 1)[0]


def test_the_emulator_holds_no_isinstance_of_a_device_class():
    tree = ast.parse(EMULATOR.read_text())
    device_names = {alias.asname or alias.name for node in ast.walk(tree)
                    if isinstance(node, ast.ImportFrom) and node.module and "devices" in node.module
                    for alias in node.names}
    assert {"RobotiqGripper", "BioGripper", "InspireHand"} <= device_names  # the test sees the imports
    tested = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "isinstance":
            tested |= {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}
    assert tested & device_names == set()


@pytest.mark.parametrize("gripper, keys", [
    ("xarm", {"enabled", "position"}),
    ("robotiq-2f85", {"activated", "position", "opening_mm", "object", "force_n"}),
    ("bio", {"enabled", "mode", "opening_mm", "object"}),
    ("bio-g1", {"enabled", "mode", "opening_mm", "object"}),
    ("inspire-rh56", {"angles"}),
])
def test_gripper_status_is_what_the_device_shows(gripper: str, keys: set[str]):
    emu = Emulator(6, gripper=gripper)
    status = emu.gripper_status()
    assert set(status) == {"gripper", "error"} | keys and status["gripper"] == gripper


@pytest.mark.parametrize("gripper, places", [("xarm", ()), ("robotiq-2f85", (0, 1)), ("bio", (0,)),
                                             ("bio-g1", (0,)), ("inspire-rh56", ())])
def test_where_a_device_takes_an_object_is_its_own(gripper: str, places: tuple[int, ...]):
    emu = Emulator(6, gripper=gripper)
    for index in (0, 1, 2):
        if index in places:
            emu.check_input("gripper-object", index, 0.0)
        else:
            with pytest.raises(ValueError, match="needs a Robotiq or BIO" if not places else "index 0"):
                emu.check_input("gripper-object", index, 0.0)


def test_a_gripper_says_itself_whether_the_physics_twin_drives_its_fingers():
    """What the physics twin drives of a gripper's own finger model comes from the device
    (``driven_fingers``): the Robotiq, the BIO G2 and G1 hand theirs out, the rest none; physics/driven.py
    tests no device class."""
    driven = {g: Emulator(6, gripper=g).gripper.device.driven_fingers(40.0) for g in GRIPPERS}
    driving = {g for g, f in driven.items() if f is not None}
    assert driving == {"robotiq-2f85", "robotiq-2f140", "bio", "bio-g1"}
    bio = driven["bio"]
    assert bio is not None and bio.opening == 150.0 and not bio.closing and not bio.met
    source = (EMULATOR.parent / "physics" / "driven.py").read_text()
    assert "isinstance" not in source and "from ..devices.gripper import DrivenFingers" in source


def test_a_gripper_says_itself_whether_the_physics_twin_moves_its_fingers():
    """The one gripper whose fingers the physics twin moves itself (the xArm gripper) says so
    (``twin_fingers``, itself); every other hands out none, and physics/component.py tests no device
    class, nor names the xArm gripper's."""
    devices = {g: Emulator(6, gripper=g).gripper.device for g in GRIPPERS}
    twin = {g: d.twin_fingers() for g, d in devices.items()}
    assert {g for g, f in twin.items() if f is not None} == {"xarm"}
    assert twin["xarm"] is devices["xarm"]
    assert all(twin[g] is None or devices[g].driven_fingers(40.0) is None for g in GRIPPERS)
    tree = ast.parse((EMULATOR.parent / "physics" / "component.py").read_text())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
             and n.func.id == "isinstance"]
    named = {n.id for c in calls for n in ast.walk(c.args[1]) if isinstance(n, ast.Name)}
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module
                and "devices" in n.module for a in n.names}
    assert named & imported == set() and "XArmGripper" not in imported
