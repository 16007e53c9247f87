"""Fleet files (`xarm-emu serve --fleet`): several arms in one process, checked before any port opens."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from helpers import free_ports, serve_ports, serve_subprocess
from helpers import run_cli as run

from xarm_emu.protocol.admin import admin_host, derive_admin_port
from xarm_emu.server.fleet import FleetError, load_fleet, parse_fleet


def fleet(*arms: dict[str, Any], **top: Any) -> dict[str, Any]:
    return {**top, "arm": list(arms)}


def test_defaults_and_serial_numbers_counted_up() -> None:
    f = parse_fleet(fleet({"model": 6}, {"model": 6, "host": "127.0.0.2"}, {"model": 7, "host": "127.0.0.3"},
                          speed=2.0))
    assert [a.robot_sn for a in f.arms] == ["XI1300", "XI1301", "XS1300"]
    assert [a.server.host for a in f.arms] == ["127.0.0.1", "127.0.0.2", "127.0.0.3"]
    assert all(a.server.port == 502 and a.server.develop_port == 30003 and a.server.speed == 2.0
               for a in f.arms)
    assert not any(a.server.admin or a.vacuum for a in f.arms) and f.config_dir is None
    assert parse_fleet(fleet({"vacuum": True})).arms[0].vacuum is True


def test_top_level_keys_are_defaults_and_config_dir_is_relative_to_the_file() -> None:
    f = parse_fleet(fleet({"port": 5020}, {"port": 5021, "model": 5, "host": "127.0.0.2"}, model=7,
                          config_dir="cfg"),
                    base=Path("/srv/fleets"))
    assert [(a.model, a.server.port) for a in f.arms] == [(7, 5020), (5, 5021)]
    assert f.config_dir == Path("/srv/fleets/cfg")
    g = parse_fleet(fleet({"trace": "a.jsonl"}, {"host": "127.0.0.2", "trace": "b.jsonl"}, faults="f.toml"),
                    base=Path("/srv"))
    assert [a.server.faults for a in g.arms] == [Path("/srv/f.toml")] * 2
    assert [a.server.trace for a in g.arms] == [Path("/srv/a.jsonl"), Path("/srv/b.jsonl")]
    with pytest.raises(FleetError, match="same trace file"):
        parse_fleet(fleet({"trace": "a.jsonl"}, {"host": "127.0.0.2", "trace": "a.jsonl"}))


@pytest.mark.parametrize("data, fragment", [
    ({}, "at least one [[arm]]"),
    (fleet({"model": 8}), "arm 1: model is one of 5, 6, 7, lite6, 850, 7t, got 8"),
    (fleet({"model": "850", "firmware": "2.0.102"}),
     "arm 1: the 850 arm needs firmware 2.1.0 or later, not 2.0.102"),
    (fleet({"model": 6, "colour": "red"}), "arm 1: unknown key 'colour'"),
    ({"arm": [{}], "robot_sn": "XI0001"}, "unknown key 'robot_sn'; known: speed, config_dir, arm"),
    (fleet({}, {"robot_sn": "xi12"}), "arm 2: robot_sn is two capital letters and four digits"),
    (fleet({"robot_sn": "XI1300"}, {"robot_sn": "XI1300", "host": "127.0.0.2"}), "already another arm's"),
    (fleet({}, {}), "arm 2: 127.0.0.1:502 is already arm 1's"),
    (fleet({"port": 70000}), "arm 1: port must be a port number"),
    (fleet({"admin": True, "host": "127.0.0.2"},
           {"admin": True, "host": "127.0.0.2", "port": 503, "normal_port": 31001, "rich_port": 31002,
            "develop_port": 31003, "admin_port": 10502}),
     "arm 2: 127.0.0.2:10502 is already arm 1's (give admin_port)"),
    (fleet({"admin": True, "host": "0.0.0.0", "port": 600, "normal_port": 31001, "rich_port": 31002,
            "develop_port": 31003},
           {"admin": True, "host": "10.0.0.1", "admin_port": 10600}),
     "arm 2: 127.0.0.1:10600 is already arm 1's (give admin_port)"),
    (fleet({"host": "0.0.0.0"}, {"host": "127.0.0.2"}), "arm 2: 127.0.0.2:502 is already arm 1's"),
    (fleet({"host": "127.0.0.1"}, {"host": "localhost"}), "arm 2: localhost:502 is already arm 1's"),
    (fleet({"port": 30001}), "arm 1: 127.0.0.1:30001 is this arm's too"),
    (fleet({"model": [6]}), "arm 1: model is one of 5, 6, 7, lite6, 850, 7t, got [6]"),
    (fleet({"admin": "yes"}), "admin is true or false"),
    (fleet({"vacuum": 1}), "vacuum is true or false"),
    (fleet({}, speed=0), "speed must be a positive number"),
    (fleet({}, config_dir=3), "config_dir must be a path string"),
])
def test_bad_fleets_are_refused_with_one_clear_message(data: dict[str, Any], fragment: str) -> None:
    with pytest.raises(FleetError) as info:
        parse_fleet(data)
    assert fragment in str(info.value)


def test_arms_on_their_own_loopback_addresses_have_admin_channels_on_the_same_port() -> None:
    """Accepted: each admin channel is on its own arm's loopback address (admin_host), port 10502;
    and with port 0 every listener, the admin channel's too, takes any free port."""
    f = parse_fleet(fleet({"admin": True}, {"admin": True, "host": "127.0.0.2"}))
    assert [(admin_host(a.server.host), derive_admin_port(a.server.port)) for a in f.arms] == [
        ("127.0.0.1", 10502), ("127.0.0.2", 10502)]
    zero = {"port": 0, "normal_port": 0, "rich_port": 0, "develop_port": 0, "admin": True}
    assert len(parse_fleet(fleet(zero, zero)).arms) == 2


def test_unreadable_or_invalid_files(tmp_path: Path) -> None:
    with pytest.raises(FleetError, match=r"^fleet file \S+missing\.toml: cannot be read: "):
        load_fleet(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[[arm]\nmodel = 6\n")
    with pytest.raises(FleetError, match="not valid TOML"):
        load_fleet(bad)
    code, out = run("serve", "--fleet", str(bad))
    assert code == 2 and "not valid TOML" in " ".join(out.split())


def test_serve_fleet_runs_every_arm_in_one_process(tmp_path: Path) -> None:
    a, _ = serve_ports()
    while True:  # the second arm's five ports (its real-time port too) apart from the first's
        b, _ = serve_ports()
        if not {*a, a[2] - 2} & {*b, b[2] - 2}:
            break
    text = "config_dir = \"cfg\"\n"
    for model, ports in ((6, a), (7, b)):
        cmd, normal, rich, develop = ports
        text += (f"[[arm]]\nmodel = {model}\nport = {cmd}\nnormal_port = {normal}\nrich_port = {rich}\n"
                 f"develop_port = {develop}\n")
    path = tmp_path / "fleet.toml"
    path.write_text(text)
    with serve_subprocess(tmp_path, "--fleet", str(path)) as proc:
        answers = []
        for ports in (a, b):
            code, out = run("status", "--json", "--wait", "30", "--port", str(ports[0]), "--report-port",
                            str(ports[3]))
            assert code == 0, (out, proc.poll() is not None and proc.communicate()[0])
            answers.append(json.loads(out)["version"])
        assert proc.poll() is None
    assert answers[0].startswith("6,6,XI1300,") and answers[1].startswith("7,7,XS1300,")


def test_a_bad_fault_schedule_of_any_arm_stops_the_fleet_before_any_port_opens(tmp_path: Path) -> None:
    (tmp_path / "bad.toml").write_text('[[fault]]\nat = 1\ndo = "error"\ncode = "C99"\n')
    cmd, normal, rich, develop = free_ports(4)
    (tmp_path / "fleet.toml").write_text(
        f"[[arm]]\nport = {cmd}\nnormal_port = {normal}\nrich_port = {rich}\ndevelop_port = {develop}\n"
        'trace = "a1.jsonl"\n[[arm]]\nhost = "127.0.0.2"\nfaults = "bad.toml"\n')
    code, out = run("serve", "--fleet", str(tmp_path / "fleet.toml"), "--config-dir", str(tmp_path))
    assert code == 2 and "fault 1" in out and "C99" in out
    assert not (tmp_path / "a1.jsonl").exists()  # arm 1 never started
    code, out = run("serve", "--fleet", str(tmp_path / "fleet.toml"), "--admin")
    assert code == 2 and "--admin" in out
