"""What the F/T sensor's configuration registers hold (205 load, 206 zero, 207-211 the parameters
of admittance and force control), as register 212 reports it: one record that the sensor, its
applications and their handlers share."""

from __future__ import annotations

from dataclasses import dataclass, field

from .controller_protocol import Controller

ZEROS6 = (0.0,) * 6


@dataclass(slots=True)
class FtConfig:
    """What registers 205 and 207-211 set, as register 212 reports it."""

    mass: float = 0.0
    centroid: tuple[float, ...] = (0.0, 0.0, 0.0)
    offsets: tuple[float, ...] = ZEROS6
    imp_coord: int = 0
    imp_c_axis: tuple[int, ...] = (0,) * 6
    M: tuple[float, ...] = ZEROS6
    K: tuple[float, ...] = ZEROS6
    B: tuple[float, ...] = ZEROS6
    fc_coord: int = 0
    fc_c_axis: tuple[int, ...] = (0,) * 6
    f_ref: tuple[float, ...] = ZEROS6
    limits: tuple[float, ...] = ZEROS6
    pid: dict[str, tuple[float, ...]] = field(
        default_factory=lambda: {k: ZEROS6 for k in ("kp", "ki", "kd", "xe_limit")})


def ft_config(ctl: Controller) -> FtConfig:
    """The F/T configuration of ``ctl``, created on first use."""
    cfg = ctl.data.ft_config
    if not isinstance(cfg, FtConfig):
        cfg = FtConfig()
        ctl.data.ft_config = cfg
    return cfg
