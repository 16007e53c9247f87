"""Cell elements on the stepped clock, in process: a conveyor on a control-box output carries a part at
its speed, a photo-eye drives a control-box input after its delay, a presence region a tool input,
feeders place parts on a timer or on an output's rising edge from their seed, and a checkpoint
carries all of it. The IO goes through the registers (134 sets outputs, 131 and 128 read inputs)."""

from __future__ import annotations

import copy
from typing import Any

import pytest

pytest.importorskip("mujoco")

from xarm_emu.controller.emulator import Emulator  # noqa: E402
from xarm_emu.controller.scene import contact  # noqa: E402
from xarm_emu.protocol.registers import REGISTERS  # noqa: E402

TABLE = {"name": "table", "point": [0, 0, -100], "normal": [0, 0, 1], "stiffness": 10.0}
BELT = {"name": "belt", "min": [200, 250, -100], "max": [560, 350, -60], "direction": [-1, 0, 0],
        "speed": 200, "output": "CO0"}
EYE = {"name": "eye", "input": "CI0", "from": [300, 230, -40], "to": [300, 370, -40], "delay": 0.02}
PART = {"name": "part", "shape": "box", "size": [40, 40, 40], "mass": 0.1, "position": [520, 300, -40]}


def scene(**tables: Any) -> Emulator:
    return Emulator(6, scene=contact.parse_scene({"plane": [TABLE], **tables}))


def call(emu: Emulator, code: int, **values: Any) -> dict[str, Any]:
    reg = REGISTERS[code]
    state, reply = emu.handle(code, reg.request.encode(values))
    assert not state & 0x60, (code, hex(state))
    return reg.reply.decode(reply) if reg.reply.fields else {}


def co0(emu: Emulator, on: bool) -> None:
    """Register 134: control-box output 0 on or off (enable bit 8, value bit 0)."""
    call(emu, 134, digital=0x0100 | int(on), sync=0)


def ci0(emu: Emulator) -> int:
    return int(call(emu, 131)["digital"] & 1)


def objects(emu: Emulator) -> dict[str, tuple[float, ...]]:
    return {o["name"]: tuple(o["position"]) for o in emu.scene_objects()}


def cell(emu: Emulator) -> dict[str, Any]:
    assert emu.physics is not None and emu.physics.cell is not None
    return emu.physics.cell.status()


def test_a_belt_on_co0_carries_the_fed_part_into_the_photo_eye_which_drives_ci0() -> None:
    emu = scene(conveyor=[BELT], sensor=[EYE], feeder=[{**PART, "count": 2, "trigger": "CO0"}])
    assert objects(emu) == {} and ci0(emu) == 1  # nothing fed yet; the input idles high
    co0(emu, True)  # the belt runs and the feeder's rising edge places part-1
    emu.advance(0.5)
    x0 = objects(emu)["part-1"][0]
    emu.advance(0.2)
    assert x0 - objects(emu)["part-1"][0] == pytest.approx(40.0, abs=0.5)  # 200 mm/s along -x
    assert cell(emu)["conveyors"][0]["running"] and cell(emu)["feeders"][0]["count"] == 1
    # the part's leading face (centre + 20 mm toward -x) reaches the beam at x = 300
    t_cut = emu.time + (objects(emu)["part-1"][0] - 20.0 - 300.0) / 200.0
    while ci0(emu) == 1:
        emu.advance(0.004)
        assert emu.time < t_cut + 0.1
    # the input follows the beam after the sensor's 20 ms (to a period, 4 ms, either side)
    assert emu.time == pytest.approx(t_cut + 0.02, abs=0.009)
    eye = cell(emu)["sensors"][0]
    assert eye == {"name": "eye", "input": "CI0", "interrupted": True, "level": 0}
    co0(emu, False)
    emu.advance(0.3)
    stopped = objects(emu)["part-1"]
    emu.advance(0.5)
    assert objects(emu)["part-1"] == pytest.approx(stopped, abs=0.01)  # the belt stopped, so did the part
    assert not cell(emu)["conveyors"][0]["running"] and ci0(emu) == 0
    emu.place_object("part-1", (300, 0, -80))  # taken away: the beam clears after its delay
    emu.advance(0.016)
    assert ci0(emu) == 0
    emu.advance(0.012)
    assert ci0(emu) == 1
    co0(emu, True)  # the second rising edge feeds part-2
    emu.advance(0.1)
    assert set(objects(emu)) == {"part-1", "part-2"} and cell(emu)["feeders"][0]["count"] == 2
    co0(emu, False)
    co0(emu, True)  # no third part: the feeder's count is spent
    emu.advance(0.1)
    assert set(objects(emu)) == {"part-1", "part-2"}


def test_a_timed_feeder_places_its_parts_from_its_seed_and_a_region_drives_a_tool_input() -> None:
    feeder = {**PART, "position": [300, 0, -80], "count": 3, "every": 0.5, "start": 0.2,
              "offset": [5, 5, 10], "seed": 3}
    region = {"name": "spot", "input": "TI1", "min": [250, -50, -100], "max": [350, 50, 0]}
    emu = scene(feeder=[feeder], sensor=[region])
    emu.advance(0.1)
    assert objects(emu) == {}
    emu.advance(0.2)
    placed = objects(emu)
    assert list(placed) == ["part-1"]
    assert cell(emu)["sensors"][0]["interrupted"] and cell(emu)["sensors"][0]["level"] == 1
    assert emu.io.tool.input(1) == 1  # a tool input idles low: active 1
    first = placed["part-1"]
    assert abs(first[0] - 300) <= 5 and abs(first[1]) <= 5 and first != (300.0, 0.0, -80.0)
    emu.place_object("part-1", (300, -200, -80))
    emu.advance(1.0)  # part-2 at 0.7 s, part-3 at 1.2 s, each on the spot, then none
    assert list(objects(emu)) == ["part-1", "part-2", "part-3"]
    emu.advance(1.0)
    assert len(objects(emu)) == 3 and cell(emu)["feeders"][0] == {"name": "part", "count": 3, "of": 3}
    again = scene(feeder=[feeder], sensor=[region])
    again.advance(0.3)
    assert objects(again)["part-1"] == first  # the same seed, the same draw to the last bit
    other = scene(feeder=[{**feeder, "seed": 4}], sensor=[region])
    other.advance(0.3)
    assert objects(other)["part-1"] != first


def test_a_checkpoint_carries_the_belt_the_beam_and_the_feeder() -> None:
    emu = scene(conveyor=[BELT], sensor=[EYE], feeder=[{**PART, "count": 3, "trigger": "CO0"}])
    co0(emu, True)
    emu.advance(0.8)
    cp = emu.checkpoint()
    status = copy.deepcopy(cell(emu))

    def rest() -> tuple[dict[str, Any], dict[str, Any], int]:
        emu.advance(0.2)  # part-1 cuts the beam at about 0.9 s
        co0(emu, False)
        emu.advance(0.1)
        co0(emu, True)  # the belt runs on: part-2 is fed, part-1 leaves the beam
        emu.advance(0.3)
        return objects(emu), copy.deepcopy(cell(emu)), ci0(emu)

    end = rest()
    assert len(end[0]) == 2 and end[1]["feeders"][0]["count"] == 2
    emu.restore(cp)
    assert cell(emu) == status
    assert rest() == end


def test_a_checkpoint_taken_while_the_beam_is_cut_carries_its_timer() -> None:
    """Saved in the period the part cuts the beam (the belt running, one part placed, the input still
    high for the sensor's 20 ms): continued, restored and continued again, the input falls in the same
    period, the belt stops and starts the same, and every part ends in the same place to the last bit."""
    emu = scene(conveyor=[BELT], sensor=[EYE], feeder=[{**PART, "count": 3, "trigger": "CO0"}])
    co0(emu, True)
    emu.advance(0.6)
    world = emu.physics.world  # type: ignore[union-attr]
    while not world.state.cell.beam[0]:
        emu.advance(0.004)
    assert ci0(emu) == 1  # cut, the input not yet low
    cp = emu.checkpoint()
    status = copy.deepcopy(cell(emu))
    assert status["conveyors"][0]["running"] and status["feeders"][0]["count"] == 1

    def rest() -> tuple[list[int], dict[str, tuple[float, ...]], dict[str, Any]]:
        levels = []
        for _ in range(10):  # the input, period by period, across its delay
            levels.append(ci0(emu))
            emu.advance(0.004)
        co0(emu, False)
        emu.advance(0.2)
        co0(emu, True)  # part-2 is fed; part-1 rides on out of the beam
        emu.advance(0.4)
        return levels, objects(emu), copy.deepcopy(cell(emu))

    end = rest()
    assert end[0][0] == 1 and end[0][-1] == 0  # the input fell within the rest
    assert set(end[1]) == {"part-1", "part-2"} and end[2]["feeders"][0]["count"] == 2
    emu.restore(cp)
    assert cell(emu) == status
    assert emu.physics.world.state.cell.beam[0]  # type: ignore[union-attr]  # cut, its timer running
    assert rest() == end


@pytest.mark.parametrize(("tables", "message"), [
    ({"conveyor": [{**BELT, "output": "CI0"}]}, "conveyor belt: output must be an output such as 'CO0'"),
    ({"conveyor": [{**BELT, "direction": [0, 0, 1]}]}, "direction must be horizontal"),
    ({"sensor": [{**EYE, "input": "TI9"}]}, "input 'TI9' is no digital IO of the tool"),
    ({"sensor": [{**EYE, "min": [0, 0, 0], "max": [1, 1, 1]}]}, "a beam (from, to) or a region"),
    ({"feeder": [{**PART, "count": 2}]}, "give 'every' (s) or 'trigger'"),
    ({"feeder": [{**PART, "count": 0, "every": 1}]}, "count must be a whole number from 1"),
    ({"feeder": [{**PART, "count": 1, "every": 1, "speed": 3}]}, "unknown key 'speed'"),
    ({"feeder": [{**PART, "count": 1, "every": 1}], "object": [{**PART, "name": "part-1"}]},
     "object part-1: the name is used twice"),
])
def test_bad_cell_tables_are_refused_in_one_line(tables: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError) as err:
        contact.parse_scene({"plane": [TABLE], **tables})
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_sensor_on_an_input_the_box_has_not_is_refused() -> None:
    with pytest.raises(ValueError, match="TI2"):
        scene(sensor=[{**EYE, "input": "TI2"}])  # an xArm 6 tool has no TI2


def test_the_3d_view_draws_the_belt_and_the_beam_with_their_state() -> None:
    from xarm_emu.viewer import scene as view

    emu = scene(conveyor=[BELT], sensor=[EYE], feeder=[{**PART, "count": 1, "trigger": "CO0"}])
    assert emu.physics is not None and emu.physics.cell is not None

    def drawn() -> dict[str, Any]:
        return {p.name: p for p in view.cell_parts(emu.physics.cell.cell, cell(emu))}  # type: ignore[union-attr]

    idle = drawn()
    assert idle["belt_belt"].color == view.BELT_STOPPED and idle["beam_eye"].color == view.BEAM_CLEAR
    assert idle["belt_belt"].position == pytest.approx((0.38, 0.3, -0.08))
    assert idle["beam_eye"].position == pytest.approx((0.3, 0.23, -0.04))
    assert idle["beam_eye"].length == pytest.approx(0.14)
    co0(emu, True)
    emu.advance(1.2)  # part-1 reaches the beam
    busy = drawn()
    assert busy["belt_belt"].color == view.BELT_RUNNING and busy["beam_eye"].color == view.BEAM_CUT
