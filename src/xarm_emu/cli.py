"""Command line interface (placeholder until the server lands)."""


def main() -> None:
    raise SystemExit("not yet")
