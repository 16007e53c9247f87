"""The release number: the one place it is written (``pyproject.toml`` reads it through setuptools'
dynamic version, ``xarm-emu --version`` prints it). docs/versioning.md says what a change of it promises."""

__version__ = "0.2.0"
