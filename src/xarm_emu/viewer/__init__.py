"""The 3D view and pendant in the browser (``serve --view``, viser): :mod:`.scene` computes what is
drawn from the emulator's state (pure), :mod:`.pendant` is the status panel, the actions and the
plot, :mod:`.app` serves them and attaches to a server (or a fleet)."""

__all__ = ["app", "pendant", "scene"]
