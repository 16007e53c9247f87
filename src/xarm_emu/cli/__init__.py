"""``xarm-emu``: run the emulator and talk to a control box from the shell.

One module per group of commands, registered here in the order ``xarm-emu --help`` lists them:

- :mod:`.serve`: ``serve`` and its options, checked before any port opens; :mod:`.serving` starts the
  servers, :mod:`.fleet` serves a fleet file's arms in worker processes.
- :mod:`.status`: ``status``, what a control box says about itself.
- :mod:`.reference`: ``registers``, ``modbus-map``, ``codes``: the manual's tables as the emulator
  holds them.
- :mod:`.admin`: the admin channel's ``inject``, ``clear``, ``set-input``, ``step`` and ``checkpoint``;
  :mod:`.scene`: ``scene``, ``scene-place``, ``scene-reset``, ``scene-add``, ``scene-remove``.
- :mod:`.sessions`: ``record``, ``plot``, ``replay``.
- :mod:`.fidelity`: ``proxy``, ``compare``, ``calibrate`` (a real box's session against the emulator).
- :mod:`.options`: what they share: the consoles, option types, the one-line exit (2 for a usage
  mistake, 1 for a runtime failure) and the admin request.
"""

from __future__ import annotations

from typing import Annotated, Any

import typer

from .. import __version__
from . import admin, fidelity, reference, scene, serve, serving, sessions, status
from .options import console
from .serve import bare_linear_track

__all__ = ["app", "bare_linear_track", "main"]

app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,
                  help="Emulator of the UFACTORY xArm control box (xArm 5/6/7, Lite 6, 850, 7T; "
                       "Developer Manual V1.6.0 and firmware 2.x).\n\n"
                       "Exit status: 0 done; 2 a usage or input mistake (an option or argument the "
                       "command refuses); 1 a runtime failure (the box unreachable, a port in use, the "
                       "admin channel refusing the token). Either way one line on stderr says what to "
                       "do next.")

app.command(cls=serve.ServeCommand)(serve.serve)
app.command()(status.status)
app.command()(reference.registers)
app.command("modbus-map")(reference.modbus_map)
app.command(name="codes")(reference.show_codes)
app.add_typer(admin.inject_app, name="inject")
app.command("scene")(scene.scene)
app.command("scene-place", context_settings={"ignore_unknown_options": True})(scene.scene_place)
app.command("scene-reset")(scene.scene_reset)
app.command("scene-add")(scene.scene_add)
app.command("scene-remove")(scene.scene_remove)
app.command()(admin.clear)
app.command("set-input", context_settings={"ignore_unknown_options": True})(admin.set_input)
app.command()(admin.step)
app.add_typer(admin.checkpoint_app, name="checkpoint")
app.command("record")(sessions.record_session)
app.command("plot")(sessions.plot_session)
app.command("replay")(sessions.replay_trace)
app.command("proxy")(fidelity.proxy)
app.command("compare")(fidelity.compare)
app.command("calibrate")(fidelity.calibrate)

#: How ``serve`` runs its servers' coroutine on the chosen loop; replace it to see what ``serve`` does
#: when a port cannot be bound (looked up here at each call).
_run = serving.run


def _run_here(coro: Any, loop: str) -> None:
    _run(coro, loop)


serving.runner = _run_here


@app.command()
def version() -> None:
    """Print the xarm-emu version."""
    console.print(__version__)


def _print_version(value: bool) -> None:
    if value:
        console.print(__version__)
        raise typer.Exit()


@app.callback()
def _options(show_version: Annotated[bool, typer.Option(
        "--version", callback=_print_version, is_eager=True, expose_value=False, allow_from_autoenv=False,
        help="Print the xarm-emu version and exit.")] = False) -> None:
    """The options of ``xarm-emu`` itself, before any command."""


def main() -> None:
    app(auto_envvar_prefix="XARM_EMU")  # every option also from XARM_EMU_<COMMAND>_<OPTION>
