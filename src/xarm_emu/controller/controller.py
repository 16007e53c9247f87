"""The emulated control box: :class:`Controller` (see :mod:`.core` for the state, dispatch and
control step, :mod:`.handlers` for the register handlers of manual section 2.1.3)."""

from __future__ import annotations

from .core import Controller

__all__ = ["Controller"]
