"""`xarm-emu codes`: the code tables of manual chapter 3 with their names and handling."""

from __future__ import annotations

from typer.testing import CliRunner

from xarm_emu import cli
from xarm_emu.protocol import codes

runner = CliRunner()


def test_codes_explains_one_label() -> None:
    result = runner.invoke(cli.app, ["codes", "C35"])
    assert result.exit_code == 0
    entry = codes.parse_label("C35")
    assert entry.name in result.output.replace("\n", " ")


def test_codes_lists_every_table() -> None:
    result = runner.invoke(cli.app, ["codes"], terminal_width=200)
    assert result.exit_code == 0
    for label in ("C1", "C22", "C35", "C37", "W11", "W14", "G11"):
        assert label in result.output


def test_codes_refuses_an_unknown_label() -> None:
    result = runner.invoke(cli.app, ["codes", "X9"])
    assert result.exit_code == 2


def test_status_names_the_error(server) -> None:  # type: ignore[no-untyped-def]
    server.call(lambda: server.emulator.inject_error(31))
    result = runner.invoke(cli.app, ["status", "--port", str(server.ports["command"]), "--report-port",
                                     str(server.ports["develop"])], terminal_width=200)
    assert result.exit_code == 0
    assert "C31" in result.output and codes.controller_error(31).name in result.output


def test_registers_command_reads_the_register_table() -> None:
    from xarm_emu.protocol.registers import REGISTERS

    result = runner.invoke(cli.app, ["registers", "21"], terminal_width=200)
    assert result.exit_code == 0
    assert REGISTERS[21].request.describe() in result.output and "queued" in result.output
    listing = runner.invoke(cli.app, ["registers"], terminal_width=250)
    assert listing.exit_code == 0
    for reg in REGISTERS.values():
        assert reg.name in listing.output
    assert runner.invoke(cli.app, ["registers", "999"]).exit_code == 2
