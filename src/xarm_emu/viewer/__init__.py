"""The 3D view and pendant in the browser (``serve --view``, viser): :mod:`.scene` computes what is
drawn from the emulator's state (pure), :mod:`.app` serves it and attaches to a server."""

__all__ = ["app", "scene"]
