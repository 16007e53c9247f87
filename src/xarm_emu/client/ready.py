"""A readiness probe: does a control box answer the protocol on its command port (manual 2.1.2)?

``python -m xarm_emu.client.ready --host 127.0.0.1 --port 502 --wait 2`` retries for up to
``--wait`` seconds until the box replies to a version request (a protocol reply, not just an open
port), then exits 0; it exits 1 when the box never answered, naming the address and the last error,
and 2 for a usage mistake. It loads the client and the protocol tables alone, so a container's
health check or a Kubernetes probe costs a short, small process: ``xarm-emu status --wait`` reads
much more of the box (and loads the whole command line) for the same answer.
"""

from __future__ import annotations

import argparse
import sys
import time

from ..protocol.frame import COMMAND_PORT
from .common import ClientError
from .sync import Client


def wait_until_answering(host: str, port: int, wait: float, timeout: float = 3.0) -> str:
    """The version string of the box at ``host:port`` once it answers; retries every 0.1 s for up to
    ``wait`` seconds, then raises the last :class:`OSError` or :class:`ClientError`."""
    deadline = time.monotonic() + max(0.0, wait)
    while True:
        try:
            with Client(host, port, timeout=timeout) as c:
                return c.get_version()
        except (OSError, ClientError):
            if time.monotonic() >= deadline:
                raise
            time.sleep(0.1)


def _port(text: str) -> int:
    value = int(text)
    if not 1 <= value <= 65535:
        raise ValueError(text)
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m xarm_emu.client.ready",
                                     description="Exit 0 once a control box answers on its command port.")
    parser.add_argument("--host", default="127.0.0.1", help="control box address")
    parser.add_argument("--port", type=_port, default=COMMAND_PORT, help="command port")
    parser.add_argument("--wait", type=float, default=0.0, help="seconds to keep retrying")
    args = parser.parse_args(argv)
    try:
        wait_until_answering(args.host, args.port, args.wait)
    except (OSError, ClientError) as exc:
        print(f"the control box at {args.host}:{args.port} does not answer: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
