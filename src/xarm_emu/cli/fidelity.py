"""``proxy``, ``compare`` and ``calibrate``: a program's session with a real box recorded, replayed into
the emulator and the emulator's estimated constants fitted to it (:mod:`xarm_emu.fidelity`)."""

from __future__ import annotations

import asyncio
import contextlib
import signal
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated

import typer

from ..model.calibration import CalibrationError
from ..model.calibration import load as load_calibration
from .options import console, err_console


def proxy(
    to: Annotated[str, typer.Option("--to", help="Address of the control box to forward to.")],
    record: Annotated[Path, typer.Option(help="Write the session to this .xrec recording.")],
    host: Annotated[str, typer.Option(help="Address to listen on (loopback by default).")] = "127.0.0.1",
    port_offset: Annotated[int, typer.Option(help="Listen on the standard ports plus this (502 needs "
                                                  "root; with 10000 the program connects to 10502, ...).")
                           ] = 0,
    to_port_offset: Annotated[int, typer.Option(help="The box's ports are the standard ones plus this.")
                              ] = 0,
) -> None:
    """Relay a program's connections to a box unchanged, recording both ways (docs/real-arms.md)."""
    from ..server.proxy import STANDARD_PORTS, Proxy, ProxyConfig
    from ..server.xrec import RecordingError, RecordWriter

    for name, off in (("--port-offset", port_offset), ("--to-port-offset", to_port_offset)):
        if not all(0 <= p + off <= 65535 for p in STANDARD_PORTS):
            err_console.print(f"{name}: the ports {min(STANDARD_PORTS) + off}..{max(STANDARD_PORTS) + off} "
                              "are not all valid")
            raise typer.Exit(2)
    cfg = ProxyConfig.offsets(to, host, port_offset, to_port_offset)
    try:
        writer = RecordWriter(record, to, cfg.to)
    except RecordingError as exc:
        err_console.print(str(exc))
        raise typer.Exit(1) from None

    async def run() -> Proxy:
        px = Proxy(cfg, writer)
        await px.start()
        err_console.print(f"proxy: {host} ports {sorted(px.ports.values())} -> {to} "
                          f"ports {sorted(cfg.to.values())}, recording to {record}")
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(NotImplementedError):
                loop.add_signal_handler(sig, stop.set)
        await stop.wait()
        await px.close()
        return px

    try:
        px = asyncio.run(run())
    except OSError as exc:
        writer.close()
        err_console.print(f"proxy: cannot listen on {host}: {exc.strerror or exc}")
        raise typer.Exit(1) from None
    lat = px.latency()
    writer.stats(lat, {"to_box": px.bytes[0], "to_program": px.bytes[1]})
    writer.close()
    if lat:
        console.print(f"{int(lat['n'])} command chunks relayed; time in the proxy: median "
                      f"{lat['p50'] * 1e3:.3f} ms, p99 {lat['p99'] * 1e3:.3f} ms, "
                      f"max {lat['max'] * 1e3:.3f} ms")
    console.print(f"{writer.records} records written to {record}")
    if writer.error:
        err_console.print(writer.error)
        raise typer.Exit(1)


@contextlib.contextmanager
def _progress(what: str) -> Iterator[Callable[[int, int], object] | None]:
    """A progress bar on stderr while a long comparison runs, when stderr is a terminal (else
    nothing: a CI log gets no bar); yields the ``progress(done, total)`` callback or ``None``."""
    if not err_console.is_terminal:
        yield None
        return
    from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeRemainingColumn(),
                  console=err_console, transient=True) as bar:
        task = bar.add_task(what, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update


def compare(
    recording: Annotated[Path, typer.Argument(help="A recording of xarm-emu proxy (.xrec).")],
    calibration: Annotated[Path | None, typer.Option(help="Replay with this calibration file.")] = None,
    tolerances: Annotated[Path | None, typer.Option(help="TOML file of tolerances (defaults in "
                                                         "docs/real-arms.md).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the comparison as JSON.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write an HTML report with plots "
                                                                       "of the worst commands.")] = None,
) -> None:
    """Replay a recording into the emulator and report the differences; exit 1 outside the tolerances."""
    import json

    from ..fidelity.compare import CompareError, code_lines, load_tolerances
    from ..fidelity.compare import compare as run_compare
    from ..fidelity.html_report import write_report
    from ..model.calibration import Calibration

    cal: Calibration | None = None
    try:
        tol = load_tolerances(tolerances)
        if calibration is not None:
            cal = load_calibration(calibration)
    except (CompareError, CalibrationError) as exc:
        err_console.print(str(exc))
        raise typer.Exit(2) from None
    try:
        with _progress("replaying") as progress:
            result = run_compare(recording, cal, tol, progress=progress)
        if output is not None:
            write_report(result, output)
    except (CompareError, CalibrationError) as exc:
        err_console.print(str(exc))
        raise typer.Exit(1) from None
    except OSError as exc:
        err_console.print(f"cannot write {output}: {exc.strerror or exc}")
        raise typer.Exit(1) from None
    if as_json:
        console.print(json.dumps(result.to_json(), default=float), soft_wrap=True)
    else:
        t = result.totals
        console.print(f"{int(t['requests'])} requests and {int(t['samples'])} real-time frames replayed "
                      f"(xArm {result.model}, firmware {result.firmware}) in {result.replay_seconds:.2f} s",
                      soft_wrap=True)
        for key in ("reply_differences", "duration_s", "path_mm", "path_deg", "torque_rms", "torque_max",
                    "current_rms", "current_max", "code_differences", "code_timing_s", "report_rate_rel"):
            if key in t:
                console.print(f"  {key:18} {t[key]:.6g}")
        for line in code_lines(result):
            console.print(f"  {line}", soft_wrap=True)
        for note in result.notes:
            console.print(f"note: {note}", soft_wrap=True)
        if t.get("undecided"):
            console.print(f"note: {int(t['undecided'])} commands the recording could not place to one "
                          "control period (--json: undecided, window)", soft_wrap=True)
            console.print(f"note: left out as inside their windows: {int(t.get('excluded_frames', 0))} "
                          f"real-time frames, {int(t.get('undecided_replies', 0))} differing replies "
                          "(--json: excluded_frames, inside)", soft_wrap=True)
        console.print("within every tolerance" if not result.failures else
                      "outside the tolerances: " + "; ".join(result.failures), soft_wrap=True)
    if result.failures:
        raise typer.Exit(1)


def calibrate(
    recording: Annotated[Path, typer.Argument(help="A recording of xarm-emu proxy (.xrec).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="The calibration file to write (TOML).")],
) -> None:
    """Fit the emulator's estimated constants to a recording, with their uncertainties."""
    from ..fidelity.calibrate import calibrate as run_calibrate
    from ..fidelity.compare import CompareError
    from ..model.calibration import dumps, save

    try:
        result = run_calibrate(recording)
        kept = f"kept at the emulator's values (not fitted): {', '.join(result.kept)}" if result.kept else ""
        save(result.calibration, output, comment=f"fitted by xarm-emu calibrate to {recording.name} "
                                                 f"({result.samples} real-time frames)\n"
                                                 + "\n".join([kept, *result.notes] if kept else result.notes))
    except (CompareError, CalibrationError, ValueError) as exc:
        err_console.print(str(exc))
        raise typer.Exit(1) from None
    console.print(dumps(result.calibration), end="")
    if kept:
        console.print(kept, soft_wrap=True)
    for note in result.notes:
        console.print(f"note: {note}", soft_wrap=True)

