"""``[[object]]`` tables in the scene file: what is read, what is refused (one line naming the object
and the key), and that a scene without objects never imports the physics engine."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from xarm_emu.controller.scene import contact

CUBE = {"name": "cube", "shape": "box", "size": [40, 40, 40], "mass": 0.1, "position": [300, -100, 20]}


def test_objects_are_read_with_their_defaults() -> None:
    scene = contact.parse_scene({"object": [CUBE, {"name": "can", "shape": "cylinder", "size": [60, 100],
                                                   "mass": 0.3, "position": [0, 300, 50], "rpy": [0, 0, 45],
                                                   "friction": 0.6, "color": "#ff0000"}]})
    cube, can = scene.objects
    assert (cube.shape, cube.size, cube.mass, cube.rpy, cube.friction) == ("box", (40, 40, 40), 0.1,
                                                                          (0, 0, 0), 1.0)
    assert can.rpy == (0, 0, 45) and can.friction == 0.6 and can.color == (1.0, 0.0, 0.0, 1.0)
    assert contact.parse_scene(scene.to_dict()) == scene


@pytest.mark.parametrize(("change", "message"), [
    ({"shape": "cone"}, "object cube: shape must be one of box, cylinder, sphere"),
    ({"size": [40, 40]}, "object cube: size must be [x, y, z] in mm"),
    ({"size": [40, 0, 40]}, "object cube: size must be > 0"),
    ({"mass": 0}, "object cube: mass must be a number > 0"),
    ({"mass": True}, "object cube: mass must be a number > 0"),
    ({"position": [1, 2, "x"]}, "object cube: position must be [x, y, z] in mm"),
    ({"friction": -1}, "object cube: friction must be a number >= 0"),
    ({"color": "red"}, "object cube: color must be"),
    ({"weight": 1}, "object cube: unknown key 'weight'"),
])
def test_bad_object_tables_are_refused_in_one_line(change: dict, message: str) -> None:
    with pytest.raises(ValueError) as e:
        contact.parse_scene({"object": [{**CUBE, **change}]})
    assert str(e.value).startswith(message) and "\n" not in str(e.value)


def test_a_name_used_twice_and_a_missing_key_are_refused() -> None:
    with pytest.raises(ValueError, match="object cube: the name is used twice"):
        contact.parse_scene({"object": [CUBE, CUBE]})
    with pytest.raises(ValueError, match="object cube: missing 'mass'"):
        contact.parse_scene({"object": [{k: v for k, v in CUBE.items() if k != "mass"}]})


def test_no_objects_no_engine(tmp_path: Path) -> None:
    """A scene of planes and boxes runs as before: the engine is not even imported."""
    code = ("import sys\n"
            "from xarm_emu.controller.scene import contact\n"
            "from xarm_emu.controller.emulator import Emulator\n"
            "t = {'point': [0, 0, 0], 'normal': [0, 0, 1], 'stiffness': 1}\n"
            "s = contact.parse_scene({'plane': [t]})\n"
            "emu = Emulator(6, scene=s)\n"
            "emu.advance(0.1)\n"
            "assert emu.physics is None\n"
            "print('mujoco' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_the_documented_scene_file_reads() -> None:
    scene = contact.load_scene(Path(__file__).parent.parent / "examples" / "pick_and_place.toml")
    assert [o.name for o in scene.objects] == ["cube"] and scene.objects[0].position[2] == -80.0
    assert scene.objects[0].size == (40.0, 40.0, 40.0)


def test_the_3d_view_draws_the_objects_where_they_are(make_server) -> None:  # type: ignore[no-untyped-def]
    pytest.importorskip("viser")
    pytest.importorskip("mujoco")
    from helpers import wait_for

    from xarm_emu.controller.emulator import Emulator

    table = {"point": [0, 0, 0], "normal": [0, 0, 1], "stiffness": 10.0}
    ball = {"name": "ball", "shape": "sphere", "size": [30], "mass": 0.05, "position": [200, 200, 15]}
    scene = contact.parse_scene({"plane": [table], "object": [CUBE, ball]})
    st = make_server(emulator=Emulator(6, scene=scene), view=True, view_port=0)
    viewer = st.server.viewer
    st.call(lambda: st.emulator.place_object("cube", (250, -50, 20), (0, 0, 30)))
    assert wait_for(lambda: st.call(lambda: st.emulator.physics.world.state.settled))
    n = viewer.updates
    assert wait_for(lambda: viewer.updates > n + 2)
    handle = st.call(lambda: viewer._handles["/objects/object_cube"])
    pose = st.call(lambda: st.emulator.scene_objects()[0])
    assert tuple(handle.position) == pytest.approx([v / 1000 for v in pose["position"]], abs=1e-3)
    assert "/objects/object_ball" in viewer._handles
