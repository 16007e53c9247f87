"""The emulator's state is one tree (controller/box_state.py): every object reachable from an
``Emulator`` either lies in ``emu.state`` (which a checkpoint copies as a whole) or is one of a short,
reasoned list of values fixed at construction, derived from the state, or the wiring between
components. A new attribute anywhere fails here until it is declared in the tree or listed below."""

from __future__ import annotations

import dataclasses
import struct
import types
from collections import deque
from collections.abc import Iterator
from typing import Any

import pytest

from xarm_emu.controller.emulator import Emulator

FIXED = "fixed at construction (model, firmware, wiring options, serial numbers)"
DERIVED = "derived from the state (a cache, recomputed or keyed on what it depends on)"
WIRING = "a reference to another part of the emulator (walked in turn)"
TRACKING = "change tracking and diagnostics of the control loop, not a value the box shows"
ENGINE = ("the physics engine's live data: a checkpoint captures it into the tree's ``physics`` part "
          "(World.capture) and a restore puts it back (World.restore)")

#: Attributes outside the state tree, by class and name, with the reason each is not state.
OUTSIDE: dict[tuple[str, str], str] = {
    ("Emulator", "model"): FIXED,
    ("Emulator", "firmware"): FIXED,
    ("Emulator", "gripper_kind"): FIXED,
    ("Emulator", "config_dir"): FIXED,
    ("Emulator", "config_message"): FIXED,  # what loading the saved configuration reported
    ("Emulator", "loaded_config"): FIXED,  # the saved configuration loaded at start (the trace's start line)
    ("Emulator", "exact_steps"): FIXED,
    ("Emulator", "physics"): WIRING,  # its world's state is the tree's ``physics`` part
    ("Emulator", "_store"): FIXED,  # the saved configuration's file (register 39/40)
    ("Emulator", "outside"): FIXED,  # the server scheduled actions act on (named in a checkpoint)
    ("Emulator", "controller"): WIRING,
    ("Emulator", "io"): WIRING,
    ("Emulator", "gripper"): WIRING,
    ("Emulator", "vacuum"): WIRING,
    ("Emulator", "lite6_gripper"): WIRING,
    ("Emulator", "linear_track"): WIRING,
    ("Emulator", "devices"): WIRING,  # the devices plugged in (controller/core/device.py)
    ("Emulator", "thermal"): WIRING,
    ("Emulator", "feedback"): WIRING,
    ("Emulator", "modbus"): WIRING,  # the tree's part (checked to be the tree's own object)
    ("Emulator", "schedule"): WIRING,  # idem
    ("Emulator", "_scheduled"): WIRING,  # the schedule's heap
    ("Emulator", "generation"): TRACKING,
    ("Emulator", "_next_event"): DERIVED,
    ("Emulator", "_settled"): TRACKING,
    ("Emulator", "periods_jumped"): TRACKING,
    ("Emulator", "_rest_cache"): DERIVED,
    ("PhysicsComponent", "world"): WIRING,
    ("PhysicsComponent", "device"): WIRING,  # the gripper on the tool bus (the tree's part)
    ("PhysicsComponent", "driven"): WIRING,  # the adapter of a gripper whose model moves its fingers
    ("PhysicsComponent", "vacuum"): WIRING,
    ("PhysicsComponent", "squeeze"): FIXED,  # from the hand's force and the finger drive's gain
    ("PhysicsComponent", "cell"): WIRING,  # the cell elements' runner; their state is the world's
    ("PhysicsComponent", "_io"): WIRING,  # the box's IO module, for a rebuilt world's cell
    ("PhysicsComponent", "lite6"): WIRING,  # the Lite 6 gripper's jaws (the tree's part)
    ("World", "scene_text"): FIXED,  # the scene's tables as JSON (a checkpoint names its world by it)
    ("CellRunner", "world"): WIRING,
    ("CellRunner", "io"): WIRING,
    ("CellRunner", "cell"): FIXED,  # the scene's conveyors, sensors and feeders
    ("CellRunner", "_geomid"): DERIVED,  # a sensor ray's output buffer, written by each ray
    ("CellRunner", "_looked"): DERIVED,  # keyed on the world's change count
    ("World", "specs"): FIXED,  # the scene's objects and the feeders' parts
    ("World", "feeder_base"): FIXED,
    ("World", "_belts"): FIXED,
    ("World", "ray_groups"): FIXED,
    ("World", "state"): ENGINE,
    ("World", "d"): ENGINE,
    ("World", "m"): FIXED,  # but the finger drive's force limit, set each period from the gripper's force
    ("World", "robot"): FIXED,
    ("World", "scene"): FIXED,
    ("World", "hand"): FIXED,
    ("World", "fingers"): FIXED,
    ("World", "objects"): FIXED,
    ("World", "_q"): FIXED,
    ("World", "_v"): FIXED,
    ("World", "_fq"): FIXED,
    ("World", "_pads"): FIXED,
    ("World", "_arm_geoms"): FIXED,
    ("World", "_arm_idx"): FIXED,
    ("World", "_finger_v"): FIXED,
    ("World", "_kind"): FIXED,
    ("World", "_kinds"): FIXED,
    ("World", "_object_geoms"): FIXED,
    ("World", "_free_v"): FIXED,
    ("World", "_free_list"): FIXED,
    ("World", "_flange_body"): FIXED,
    ("World", "_size"): FIXED,
    ("World", "_initial"): FIXED,  # the objects where the scene file puts them (scene-reset)
    ("World", "_near_m"): FIXED,  # the nearness test's model
    ("World", "_near_d"): DERIVED,  # the nearness test's kinematics, keyed on the world and the joints
    ("World", "_near_key"): DERIVED,
    ("World", "_far_key"): DERIVED,
    ("World", "_far_out"): DERIVED,
    ("World", "_version"): DERIVED,  # counts the engine's changes, keys the contacts read below
    ("World", "_scanned"): DERIVED,
    ("World", "_rows"): DERIVED,
    ("World", "_pad_map"): DERIVED,
    ("Controller", "model"): FIXED,
    ("Controller", "firmware"): FIXED,
    ("Controller", "dof"): FIXED,
    ("Controller", "_per_joint"): FIXED,  # the per-joint fields of the firmware's register table
    ("Controller", "period"): FIXED,
    ("Controller", "robot_sn"): FIXED,
    ("Controller", "box_sn"): FIXED,
    ("Controller", "registers"): FIXED,  # the register table of the firmware and attached devices
    ("Controller", "_handlers"): FIXED,
    ("Controller", "_routes"): FIXED,  # the mode routes of the binding table, for this firmware
    ("Controller", "_float_checked"): FIXED,
    ("Controller", "_inf_unchanged"): FIXED,
    ("Controller", "components"): WIRING,
    ("Controller", "hooks"): WIRING,
    ("Controller", "executor"): WIRING,
    ("Controller", "data"): WIRING,
    ("Controller", "settings"): WIRING,
    ("Controller", "strict"): FIXED,  # a test switch: raise instead of logging internal errors
    ("Controller", "_period_per_joint"): FIXED,
    ("Controller", "_zeros"): FIXED,
    ("Controller", "_still_rates"): DERIVED,
    ("Controller", "_pose_cache"): DERIVED,
    ("Controller", "_torque_cache"): DERIVED,
    ("Controller", "_limits_cache"): DERIVED,
    ("Executor", "model"): FIXED,
    ("Executor", "_bounds"): FIXED,
    ("Executor", "data"): WIRING,
    ("Hooks", "tool_error"): WIRING,
    ("Hooks", "on_save"): WIRING,
    ("Hooks", "on_clean_conf"): WIRING,
    ("IOModule", "data"): WIRING,
    ("IOModule", "_ctl"): WIRING,
    ("IOModule", "sync_io"): FIXED,
    ("GripperModule", "data"): WIRING,
    ("GripperModule", "gripper"): WIRING,
    ("GripperModule", "device"): WIRING,
    ("GripperModule", "tool_baud"): WIRING,
    ("GripperModule", "box_devices"): WIRING,
    ("XArmGripper", "data"): WIRING,
    ("XArmGripper", "version"): FIXED,
    ("RobotiqGripper", "data"): WIRING,
    ("RobotiqGripper", "model"): FIXED,
    ("BioGripper", "data"): WIRING,
    ("VacuumGripper", "data"): WIRING,
    ("VacuumGripper", "tool"): WIRING,
    ("Lite6Gripper", "data"): WIRING,
    ("Lite6Gripper", "tool"): WIRING,
    ("Lite6Gripper", "spec"): FIXED,
    ("LinearTrack", "data"): WIRING,
    ("LinearTrack", "length"): FIXED,
    ("LinearTrack", "version"): FIXED,
    ("LinearTrack", "sn"): FIXED,
    ("ThermalModel", "data"): WIRING,
    ("ThermalModel", "dof"): FIXED,
    ("ThermalModel", "ambient"): FIXED,
    ("ThermalModel", "_tau"): FIXED,
    ("ThermalModel", "_k"): FIXED,
    ("ThermalModel", "_idle"): FIXED,
    ("FtSensorComponent", "ctl"): WIRING,
    ("FeedbackQueue", "data"): WIRING,
}

_ATOMS = (int, float, str, bytes, bool, complex, type(None), types.FunctionType, types.BuiltinFunctionType,
          type, types.ModuleType)


def _own(obj: object) -> bool:
    return type(obj).__module__.startswith("xarm_emu.")


def _frozen(obj: object) -> bool:
    return dataclasses.is_dataclass(obj) and type(obj).__dataclass_params__.frozen  # type: ignore[attr-defined]


def _attributes(obj: object) -> dict[str, Any]:
    out = dict(vars(obj)) if hasattr(obj, "__dict__") else {}
    for klass in type(obj).__mro__:
        for slot in getattr(klass, "__slots__", ()):
            if hasattr(obj, slot):
                out[slot] = getattr(obj, slot)
    return out


def _children(obj: object) -> list[Any]:
    if isinstance(obj, dict):
        return [*obj.keys(), *obj.values()]
    if isinstance(obj, (list, tuple, set, frozenset, deque)):
        return list(obj)
    if isinstance(obj, types.MethodType):
        return [obj.__self__]
    if isinstance(obj, _ATOMS):
        return []
    if _own(obj) or dataclasses.is_dataclass(obj):
        return list(_attributes(obj).values())
    return []


def _reach(root: object, stop: set[int]) -> dict[int, object]:
    seen: dict[int, object] = {}
    stack = [root]
    while stack:
        obj = stack.pop()
        if id(obj) in seen or id(obj) in stop:
            continue
        seen[id(obj)] = obj
        stack.extend(_children(obj))
    return seen


def _shared(emu: Emulator) -> set[int]:
    """What a checkpoint refers to by name instead of writing: the model, the controller, the
    emulator and its fixed components (referred to by plans, tasks and scheduled actions)."""
    return {id(o) for o in emu._fixed().values()}


def _mutable(obj: object) -> bool:
    return not isinstance(obj, (*_ATOMS, tuple, frozenset)) and not _frozen(obj)


def _outside(emu: Emulator) -> Iterator[tuple[str, object, str]]:
    """(path, owner, attribute) of every attribute of an emulator object that is not in the tree."""
    tree = _reach(emu.state, _shared(emu))
    seen: set[int] = set()
    stack: list[tuple[str, object]] = [("emu", emu)]
    while stack:
        path, obj = stack.pop()
        if id(obj) in seen or (id(obj) in tree and _mutable(obj)):
            continue
        seen.add(id(obj))
        if _own(obj) and _mutable(obj):
            for name, value in _attributes(obj).items():
                yield path, obj, name
                if OUTSIDE.get((type(obj).__name__, name)) == WIRING:
                    stack.append((f"{path}.{name}", value))
        else:
            stack.extend((f"{path}[]", c) for c in _children(obj))


def _moving_box(**kw: Any) -> Emulator:
    if "scene" in kw:
        pytest.importorskip("mujoco")
        from xarm_emu.controller.scene import contact

        kw = {**kw, "scene": contact.parse_scene(kw["scene"])}
    emu = Emulator(6, **kw)
    for code, params in ((11, bytes([8, 1])), (19, bytes([0])), (12, bytes([0]))):
        emu.handle(code, params)
    emu.handle(23, struct.pack("<10f", 0.4, -0.2, 0, 0, 0.1, 0, 0, 0.6, 4.0, 0))
    emu.handle(21, struct.pack("<9f", 250, 0, 300, 3.1416, 0, 0, 100, 1000, 0))
    emu.handle(142, struct.pack("<BBf", 2, 1, 0.5))  # a delayed output
    emu.at(5.0, emu.touch)  # a pending scheduled action
    emu.advance(0.3)
    return emu


BOXES = {
    "xarm gripper": {},
    "vacuum, track, F/T": {"vacuum": True, "linear_track": 700, "ft_sensor": True, "firmware": "2.7.103"},
    "robotiq": {"gripper": "robotiq-2f85"},
    "bio": {"gripper": "bio", "firmware": "2.7.103"},
    "physics world": {"scene": {"plane": [{"point": [0, 0, -100], "normal": [0, 0, 1], "stiffness": 10.0}],
                                "object": [{"name": "cube", "shape": "box", "size": [40, 40, 40], "mass": 0.1,
                                            "position": [300, -100, -80]}]}},
    "cell": {"scene": {"conveyor": [{"name": "belt", "min": [200, 250, -100], "max": [560, 350, -60],
                                     "direction": [-1, 0, 0], "speed": 200}],
                       "sensor": [{"name": "eye", "input": "CI0", "from": [300, 230, -40],
                                   "to": [300, 370, -40]}],
                       "feeder": [{"name": "part", "shape": "box", "size": [40, 40, 40], "mass": 0.1,
                                   "position": [520, 300, -40], "count": 2, "every": 0.1}]}},
}


@pytest.mark.parametrize("kw", BOXES.values(), ids=BOXES.keys())
def test_every_mutable_value_is_in_the_state_tree_or_listed(kw: dict[str, Any]) -> None:
    emu = _moving_box(**kw)
    unlisted = sorted({f"{path}.{name} ({type(obj).__name__})" for path, obj, name in _outside(emu)
                       if (type(obj).__name__, name) not in OUTSIDE})
    assert unlisted == [], "mutable values outside the state tree (declare them in box_state.py):\n" + \
        "\n".join(unlisted)


@pytest.mark.parametrize("kw", BOXES.values(), ids=BOXES.keys())
def test_the_components_work_on_the_trees_own_parts(kw: dict[str, Any]) -> None:
    """Each component's ``data`` is the tree's part (so the tree is the state, not a copy of it),
    also after a restore has replaced the tree."""
    emu = _moving_box(**kw)
    for _ in range(2):
        st = emu.state
        assert emu.controller.data is st.controller and emu.controller.settings is st.settings
        assert emu.controller.executor.data is st.controller.motion
        assert emu.io.data is st.io and emu.gripper.data is st.tool_bus
        assert emu.gripper.gripper.data is st.xarm_gripper and emu.thermal.data is st.thermal
        assert emu._scheduled is st.schedule.heap
        if emu.feedback is None:
            assert st.feedback is None
        else:
            assert emu.feedback.data is st.feedback
        for part in (emu.vacuum, emu.lite6_gripper):
            assert part is None or part.tool is st.io.tool
        emu.restore(emu.checkpoint())


@pytest.mark.parametrize("kw", BOXES.values(), ids=BOXES.keys())
def test_a_checkpoint_shares_no_mutable_object_with_the_live_box(kw: dict[str, Any]) -> None:
    emu = _moving_box(**kw)
    shared = _shared(emu)
    cp = emu.checkpoint()
    tree, saved = emu.state, cp.state  # both held, so that no id is reused while they are compared
    live = {i for i, o in _reach(tree, shared).items() if _mutable(o)}
    kept = {i for i, o in _reach(saved, shared).items() if _mutable(o)}
    assert live & kept == set()
    emu.restore(cp)
    restored = emu.state
    assert {i for i, o in _reach(restored, shared).items() if _mutable(o)} & kept == set()


#: Classes in the tree that still keep their values in an instance dict (plain classes, not
#: dataclasses): the IO boards and the executor's plans.
UNSLOTTED = {"ToolIO", "ControlBoxGpio", "_JointPlan", "_CartesianPlan", "_DwellPlan"}


@pytest.mark.parametrize("kw", BOXES.values(), ids=BOXES.keys())
def test_no_value_can_be_attached_to_a_part_of_the_state(kw: dict[str, Any]) -> None:
    """Every dataclass of the tree is slotted: a value not declared in it cannot be set."""
    emu = _moving_box(**kw)
    checked = set()
    for obj in _reach(emu.state, _shared(emu)).values():
        if not (_own(obj) and _mutable(obj)):
            continue
        if type(obj).__name__ in UNSLOTTED:
            continue
        with pytest.raises(AttributeError):
            obj.undeclared = 1  # type: ignore[attr-defined]
        checked.add(type(obj).__name__)
    assert {"EmulatorState", "ControllerState", "PlanState", "Settings", "IOState"} <= checked


def test_serving_a_box_adds_nothing_outside_the_tree() -> None:
    """The server attaches its feedback queue, report streams and admin channel without leaving a
    value on the emulator that the tree does not hold."""
    from xarm_emu.testing import running_emulator

    with running_emulator(6, firmware="2.7.103", admin=True, linear_track=700, ft_sensor=True) as st:
        emu = st.emulator
        unlisted = st.call(lambda: sorted({f"{path}.{name}" for path, obj, name in _outside(emu)
                                           if (type(obj).__name__, name) not in OUTSIDE}))
    assert unlisted == []
