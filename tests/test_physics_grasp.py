"""Objects and grasps on the stepped clock, in process: a pick-and-place with the xArm gripper through
the registers (21 lines, 124 the gripper's Modbus registers) ends with the cube where it was put;
the same program twice, and a checkpoint restored before the grasp, give identical object poses."""

from __future__ import annotations

import math
import struct
import time
from typing import Any

import numpy as np
import pytest

pytest.importorskip("mujoco")

from xarm_emu.controller.emulator import Emulator  # noqa: E402
from xarm_emu.controller.scene import contact  # noqa: E402
from xarm_emu.protocol import rtu  # noqa: E402
from xarm_emu.protocol.registers import REGISTERS  # noqa: E402

#: The table top (mm): 100 mm below the arm's mounting face (the arm on a pedestal), so the gripper
#: hanging down at the zero pose (TCP at z = -60) is above it.
TZ = -100.0
TABLE = {"name": "table", "point": [0, 0, TZ], "normal": [0, 0, 1], "stiffness": 10.0}
CUBE = {"name": "cube", "shape": "box", "size": [40, 40, 40], "mass": 0.1, "position": [300, -100, TZ + 20]}
SCENE = {"plane": [TABLE], "object": [CUBE]}
TCP_Z = 172.0  # the xArm gripper's TCP offset: the fingertips


def call(emu: Emulator, code: int, **values: Any) -> dict[str, Any]:
    reg = emu.controller.registers[code]
    state, reply = emu.handle(code, reg.request.encode(values))
    assert not state & 0x60, (code, hex(state))
    return reg.reply.decode(reply) if reg.reply.fields else {}


def gripper(emu: Emulator, pdu: bytes) -> tuple[int, ...]:
    out = call(emu, 124, host=9, rtu=pdu)
    slave, func, values = rtu.parse_reply(bytes(out["rtu"]))
    assert slave == 8, (func, values)
    return values


def gripper_position(emu: Emulator) -> int:
    hi, lo = gripper(emu, rtu.read_request(8, 0x0702, 2))
    return int(struct.unpack(">i", struct.pack(">HH", hi, lo))[0])


def grip(emu: Emulator, pulses: int) -> int:
    """Move the fingers toward ``pulses`` and wait as the SDK does: until the status says stopped (0)
    or stopped on an object (2); returns the position then."""
    gripper(emu, rtu.write_multiple_request(8, 0x0700, struct.unpack(">HH", struct.pack(">i", pulses))))
    for _ in range(100):
        emu.advance(0.1)
        (status,) = gripper(emu, rtu.read_request(8, 0x0000, 1))
        if status & 3 in (0, 2):
            break
    return gripper_position(emu)


def line(emu: Emulator, x: float, y: float, z: float) -> None:
    call(emu, 21, pose=(x, y, z, math.pi, 0.0, 0.0), speed=150.0, acc=2000.0, mvtime=0.0)
    while call(emu, 13)["state"] == 1 or call(emu, 14)["cmdnum"]:
        emu.advance(0.1)


def cube(emu: Emulator) -> Any:
    assert emu.physics is not None
    return emu.physics.world.poses()[0]


def ready() -> Emulator:
    return prepare(Emulator(6, scene=contact.parse_scene(SCENE)))


def prepare(emu: Emulator) -> Emulator:
    call(emu, 35, pose=(0.0, 0.0, TCP_Z, 0.0, 0.0, 0.0))
    call(emu, 11, joint=8, enable=1)
    call(emu, 19, mode=0)
    call(emu, 12, state=0)
    gripper(emu, rtu.write_multiple_request(8, 0x0100, [1]))  # enable
    gripper(emu, rtu.write_multiple_request(8, 0x0303, [3000]))  # speed
    return emu


def pick(emu: Emulator) -> int:
    """Open, above, down, close; returns the position the close reported."""
    grip(emu, 850)
    line(emu, 300, -100, TZ + 150)
    line(emu, 300, -100, TZ + 15)
    return grip(emu, 0)


def place(emu: Emulator) -> None:
    line(emu, 300, 100, TZ + 115)
    line(emu, 300, 100, TZ + 16)
    grip(emu, 850)
    line(emu, 300, 100, TZ + 150)
    emu.advance(0.5)


def test_pick_and_place_with_the_xarm_gripper_ends_where_the_cube_was_put() -> None:
    emu = ready()
    closed = pick(emu)
    z0 = cube(emu).position[2]
    assert closed * 0.1 == pytest.approx(40.0, abs=2.0)  # the opening is the cube's width
    assert cube(emu).held
    line(emu, 300, -100, TZ + 115)
    assert cube(emu).position[2] - z0 == pytest.approx(100.0, abs=2.0)
    place(emu)
    end = cube(emu)
    assert not end.held
    assert end.position[0] == pytest.approx(300.0, abs=3.0)
    assert end.position[1] == pytest.approx(100.0, abs=3.0)
    assert end.position[2] == pytest.approx(TZ + 20.0, abs=1.0)
    assert abs(end.rpy[0]) < 2.0 and abs(end.rpy[1]) < 2.0


def test_same_program_twice_and_a_restored_checkpoint_give_identical_poses() -> None:
    first = ready()
    line(first, 300, -100, TZ + 150)
    cp = first.checkpoint()
    pick(first)
    place(first)
    a = first.physics.world.poses()  # type: ignore[union-attr]
    second = ready()
    line(second, 300, -100, TZ + 150)
    pick(second)
    place(second)
    assert second.physics.world.poses() == a  # type: ignore[union-attr]
    first.restore(cp)
    pick(first)
    place(first)
    assert first.physics.world.poses() == a  # type: ignore[union-attr]


def test_an_arm_moving_without_objects_does_not_step_an_engine() -> None:
    emu = Emulator(6, scene=contact.parse_scene({"plane": [TABLE]}))
    assert emu.physics is None


def speeds(repeats: int) -> tuple[float, float]:
    """The pick-and-place with the cube in the engine, and the same moves without objects, as arm
    seconds per second of this thread's processor time (another process on the machine does not
    change it), the best of ``repeats`` runs of each taken in turns (also run by ``make bench``)."""
    def program(emu: Emulator) -> float:
        t0 = time.thread_time()
        pick(emu)
        line(emu, 300, -100, TZ + 115)
        place(emu)
        return emu.time / (time.thread_time() - t0)

    ready()  # warm the kinematics code and the engine
    with_objects, bare = 0.0, 0.0
    for _ in range(repeats):
        bare = max(bare, program(prepare(Emulator(6))))
        with_objects = max(with_objects, program(ready()))
    return with_objects, bare


def test_the_engine_steps_only_while_something_is_near_an_object() -> None:
    """The engine's own clock advances one 4 ms step a period, and only while the arm or the fingers
    are near an object or an object is settling: in the pick-and-place it runs 5.7 s of the arm's
    12.5 s (two steps every period would be 25 s)."""
    emu = ready()
    world = emu.physics.world  # type: ignore[union-attr]
    arm0, engine0 = emu.time, world.d.time
    pick(emu)
    line(emu, 300, -100, TZ + 115)
    place(emu)
    arm, engine = emu.time - arm0, world.d.time - engine0
    assert arm > 10.0
    assert 0.2 * arm < engine < 0.6 * arm


def test_speed_against_the_same_moves_without_objects() -> None:
    """What the engine's steps cost: the pick-and-place costs about 3x the controller alone (on a
    2-core machine with one core busy 21-34x real time against 59-100x, a ratio of 1.9-3.7 on
    processor time, 4.2 once in a full suite run); with two steps every period it cost 7x."""
    with_objects, bare = speeds(5)
    print(f"pick-and-place: {with_objects:.0f}x real time (without objects {bare:.0f}x)")
    assert with_objects > bare / 5.0


@pytest.mark.parametrize("sensitivity", [3, 0])
def test_pushing_the_tool_into_the_table_raises_c31_at_sensitivity_3_not_0(sensitivity: int) -> None:
    """The TCP driven into the table at 50 mm/s: the table's reaction enters the joint torques."""
    emu = ready()
    call(emu, 37, sensitivity=sensitivity)
    call(emu, 12, state=0)
    line(emu, 200, 0, TZ + 50)
    call(emu, 21, pose=(200.0, 0.0, TZ - 40.0, math.pi, 0.0, 0.0), speed=50.0, acc=2000.0, mvtime=0.0)
    emu.advance(2.5)
    (_, reply) = emu.handle(15, b"")
    error = REGISTERS[15].reply.decode(reply)["error"]
    z = emu.controller.tcp_matrix()[2, 3]
    if sensitivity:
        assert error == 31
        assert TZ - 30.0 < z < TZ  # stopped in the table, short of the target
    else:
        assert error == 0
        assert z == pytest.approx(TZ - 40.0, abs=0.1)


def test_jumping_over_idle_periods_gives_the_same_poses_as_stepping_each() -> None:
    """A cube dropped from 30 mm falls, settles; the arm then waits and the fingers close on nothing:
    the stepped clock's jump over idle periods (controller/emulator.py) leaves every pose as stepping
    each period does."""
    def program(exact: bool) -> tuple[Any, int, int]:
        emu = ready()
        emu.exact_steps = exact
        emu.place_object("cube", (300.0, -100.0, TZ + 50.0), (10.0, 0.0, 0.0))
        emu.advance(1.5)
        line(emu, 200, 0, TZ + 150)
        grip(emu, 300)
        emu.advance(3.0)
        return emu.scene_objects(), gripper_position(emu), emu.periods_jumped

    stepped, jumped = program(True), program(False)
    assert stepped[:2] == jumped[:2]
    assert stepped[2] == 0 and jumped[2] > 500  # the settled world let the clock jump
    assert stepped[0][0]["position"][2] == pytest.approx(TZ + 20.0, abs=0.5)  # it fell onto the table


def test_a_cube_too_heavy_for_the_grip_slips_out_and_is_not_held() -> None:
    """3 kg with friction 0.3: the pads' 2 x 30 N grip holds at most 18 N of its 29.4 N weight."""
    heavy = {**CUBE, "mass": 3.0, "friction": 0.3}
    emu = prepare(Emulator(6, scene=contact.parse_scene({"plane": [TABLE], "object": [heavy]})))
    closed = pick(emu)
    assert closed * 0.1 == pytest.approx(40.0, abs=2.0)
    line(emu, 300, -100, TZ + 115)
    emu.advance(0.5)
    end = cube(emu)
    assert end.position[2] < TZ + 25.0  # it stayed down (or fell back)
    assert not end.held


@pytest.mark.parametrize("wait_periods", [0, 1, 3])
def test_a_cube_slipping_out_raises_no_collision(wait_periods: int) -> None:
    """3 kg with friction 0.5 slips out of the pads as the arm lifts (the lift started 0, 1 or 3
    periods after the grip): the fingers close on at the gripper's speed instead of springing
    into the cube's edge, so no contact force reaches the joints and no C31 stops the lift."""
    heavy = {**CUBE, "mass": 3.0, "friction": 0.5}
    emu = prepare(Emulator(6, scene=contact.parse_scene({"plane": [TABLE], "object": [heavy]})))
    assert call(emu, 13)["state"] != 4 and emu.controller.settings.collision_sensitivity
    pick(emu)
    emu.advance(wait_periods * emu.controller.period)
    line(emu, 300, -100, TZ + 115)  # asserts that no error stops it
    assert emu.controller.tcp_matrix()[2, 3] == pytest.approx(TZ + 115, abs=0.1)
    end = cube(emu)
    assert not end.held and end.position[2] == pytest.approx(TZ + 20.0, abs=1.0)


def test_the_ft_sensor_reads_the_tables_reaction_in_a_scene_with_objects() -> None:
    from xarm_emu.controller.devices import ft_sensor

    emu = prepare(Emulator(6, scene=contact.parse_scene(SCENE), ft_sensor=True, ft_noise=False,
                           firmware="1.11.100"))
    assert not emu.handle(201, b"\x01")[0] & 0x60  # switch the sensor on
    call(emu, 37, sensitivity=0)
    call(emu, 12, state=0)
    line(emu, 200, 0, TZ + 10)
    assert np.linalg.norm(ft_sensor.reading(emu.controller)[:3]) < 1.0  # above the table: nothing
    line(emu, 200, 0, TZ - 5)
    force = ft_sensor.reading(emu.controller)[:3]
    assert np.linalg.norm(force) == pytest.approx(50.0, rel=0.02)  # 5 mm into 10 N/mm


@pytest.mark.parametrize("sensitivity", [3, 0])
def test_pushing_a_cube_against_a_wall_raises_c31_from_the_contact(sensitivity: int) -> None:
    """The closed fingers push a cube along the table into a fixed block at 50 mm/s: the cube's push
    on the hand, from the engine's contacts, enters the joint torques."""
    wall = {"name": "wall", "min": [250, 0, TZ], "max": [350, 50, TZ + 100], "stiffness": 10.0}
    part = {**CUBE, "position": [300, -35, TZ + 20]}
    emu = prepare(Emulator(6, scene=contact.parse_scene({"plane": [TABLE], "box": [wall], "object": [part]})))
    call(emu, 37, sensitivity=sensitivity)
    call(emu, 12, state=0)
    line(emu, 300, -110, TZ + 60)
    line(emu, 300, -110, TZ + 15)
    call(emu, 21, pose=(300.0, 0.0, TZ + 15, math.pi, 0.0, 0.0), speed=50.0, acc=2000.0, mvtime=0.0)
    emu.advance(3.0)
    error = REGISTERS[15].reply.decode(emu.handle(15, b"")[1])["error"]
    assert error == (31 if sensitivity else 0)
    if sensitivity:  # stopped by the cube pressed against the wall, the tool short of the wall itself
        tcp = emu.controller.tcp_matrix()[:3, 3]
        assert -60.0 < tcp[1] < -10.0, tcp
        assert cube(emu).position[1] > -36.0


#: A block under the elbow (the link-3 capsule) at J2 = 1.2 rad, its top 8 mm below the capsule,
#: clear of the wrist at the zero pose; the cube (the engine runs for a scene with objects) far off.
ELBOW_BLOCK = {"name": "block", "min": [280, -80, TZ], "max": [380, 80, 190], "stiffness": 10.0}
FAR_CUBE = {**CUBE, "position": [-300, 300, TZ + 20]}


@pytest.mark.parametrize("sensitivity", [3, 0])
def test_the_elbow_driven_into_a_block_raises_c31_at_sensitivity_3_not_0(sensitivity: int) -> None:
    """J2 turns the elbow down into the block at about 50 mm/s: the link's contact in the engine
    enters the joint torques as ``J^T f``; without detection the arm goes on to its target, the
    engine never pushing it off."""
    tables = {"plane": [TABLE], "box": [ELBOW_BLOCK], "object": [FAR_CUBE]}
    emu = Emulator(6, scene=contact.parse_scene(tables))
    call(emu, 11, joint=8, enable=1)
    call(emu, 19, mode=0)
    call(emu, 37, sensitivity=sensitivity)
    call(emu, 12, state=0)
    move = {"speed": 0.5, "acc": 10.0, "mvtime": 0.0}
    call(emu, 23, joints=(0.0, 1.2, 0.0, 0.0, 0.0, 0.0, 0.0), **move)
    emu.advance(4.0)
    assert emu.controller.error_code == 0
    assert not emu.physics.world.touching_arm()  # type: ignore[union-attr]
    call(emu, 23, joints=(0.0, 1.35, 0.0, 0.0, 0.0, 0.0, 0.0), speed=0.16, acc=10.0, mvtime=0.0)
    emu.advance(1.5)
    (_, reply) = emu.handle(15, b"")
    error = REGISTERS[15].reply.decode(reply)["error"]
    q2 = float(emu.controller.q[1])
    if sensitivity:
        assert error == 31
        assert 1.2 < q2 < 1.35  # stopped in the block, short of the target
    else:
        assert error == 0
        assert q2 == pytest.approx(1.35, abs=1e-6)


def test_a_cube_added_through_the_admin_channel_is_listed_at_once_and_picked() -> None:
    """``scene-add`` rebuilds the engine of a running emulator: the new cube is listed before another
    period runs, the arm and the object already there are where they were, and the next grasp
    picks the cube; ``scene-remove`` takes it out; a checkpoint of the scene before comes back with
    that scene."""
    import json

    from xarm_emu.client.admin import AdminClient
    from xarm_emu.testing import running_emulator

    ball = {"name": "ball", "shape": "sphere", "size": [30], "mass": 0.05, "position": [0, 300, TZ + 15]}
    with running_emulator(6, scene={"plane": [TABLE], "object": [ball]}, stepped=True, admin=True) as st:
        emu = st.emulator
        st.call(lambda: (prepare(emu), line(emu, 300, -100, TZ + 150)))
        before = st.call(lambda: (emu.controller.q.copy(), emu.scene_objects(), emu.checkpoint()))
        q0, objects0, cp = before  # type: ignore[misc]
        with AdminClient("127.0.0.1", st.ports["admin"]) as a:
            a.request("scene-add", tables={"object": [CUBE]})
            listed = json.loads(a.request("scene-objects"))["objects"]
            assert [o["name"] for o in listed] == ["ball", "cube"]
            assert listed[0] == json.loads(json.dumps(objects0[0]))  # the ball where it was, to the bit
            assert listed[1]["position"] == pytest.approx(CUBE["position"], abs=1e-9)
            assert st.call(lambda: emu.controller.q.tolist()) == q0.tolist()  # the arm untouched
            closed = st.call(lambda: pick(emu))
            assert closed * 0.1 == pytest.approx(40.0, abs=2.0)
            st.call(lambda: line(emu, 300, -100, TZ + 115))
            lifted = json.loads(a.request("scene-objects"))["objects"][1]
            assert lifted["held"] and lifted["position"][2] == pytest.approx(TZ + 120.0, abs=2.0)
            a.request("scene-remove", name="cube")
            assert [o["name"] for o in json.loads(a.request("scene-objects"))["objects"]] == ["ball"]
        st.call(lambda: emu.restore(cp))
        assert st.call(lambda: emu.scene_objects()) == objects0


def _tool_outputs(emu: Emulator, *words: float) -> None:
    """Register 127 writes to the tool's output word (0x0A15), as the SDK's Lite 6 gripper calls."""
    for w in words:
        call(emu, 127, host=9, addr=0x0A15, value=w)


def test_the_lite6_gripper_jaws_grip_carry_and_release_a_part() -> None:
    """The Lite 6 gripper's jaws are bodies of the engine: closed by TO1 (the SDK's
    ``close_lite6_gripper``: 0x0100 then 0x0202) they stop on a 12 mm cube and hold it while the arm
    lifts it 50 mm; opened (0x0101 then 0x0200) they let it fall back onto the table."""
    part = {"name": "cube", "shape": "box", "size": [12, 12, 12], "mass": 0.02, "position": [250, 0, TZ + 6]}
    emu = Emulator("lite6", scene=contact.parse_scene({"plane": [TABLE], "object": [part]}))
    call(emu, 35, pose=(0.0, 0.0, 81.1, 0.0, 0.0, 0.0))
    call(emu, 11, joint=8, enable=1)
    call(emu, 19, mode=0)
    call(emu, 12, state=0)
    line(emu, 250, 0, TZ + 60)
    line(emu, 250, 0, TZ + 4)
    assert not cube(emu).held
    _tool_outputs(emu, 256.0, 514.0)  # close
    emu.advance(0.5)
    assert emu.lite6_gripper is not None and emu.lite6_gripper.opening == 0.0
    assert cube(emu).held
    opening = emu.physics.world.opening()  # type: ignore[union-attr]
    assert opening == pytest.approx(12.0, abs=0.5)  # the jaws stopped on the part
    z0 = cube(emu).position[2]
    line(emu, 250, 0, TZ + 54)
    assert cube(emu).held and cube(emu).position[2] - z0 == pytest.approx(50.0, abs=1.5)
    _tool_outputs(emu, 257.0, 512.0)  # open
    emu.advance(1.0)
    end = cube(emu)
    assert not end.held and end.position[2] == pytest.approx(TZ + 6.0, abs=1.0)
