"""Link inertial parameters, motor torque constants and joint voltage of every model of ``model.robots``.

Source of the link tables: the vendor's published inertial sets ``xarm5_type5_HT_BR2``,
``xarm6_type6_HT_BR2`` and ``xarm7_type7_HT_BR2`` (xArm-Developer/xarm_ros2, ``xarm_description/config/
link_inertial``; the "Model 3" tables of UFACTORY's "kinematic and dynamic parameters" article), which the
vendor's URDF selects by default, and from the same place ``xarm6_type9_HT_BR2`` (Lite 6),
``xarm6_type12_HT_LDBR2`` (850) and ``xarm7_type13_HT_BR2`` (xArm 7T). The numbers were read from those
sets and written here in the project's units: mass in kg, centre of mass (COM) in mm in the link frame,
inertia tensor in kg.m^2 about the COM, axes of the link frame.

Link ``i`` frame is the frame of joint ``i`` after its rotation (``model.robots``), so the last link's
frame is the flange frame. The fixed base link carries no joint torque and is left out.

Torque constants and the joint voltage are not published by UFACTORY; the values below are assumptions
(documented per constant) chosen so that currents land in a plausible range for the motor sizes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .robots import RobotModel


@dataclass(frozen=True)
class LinkInertial:
    """Rigid-body parameters of one moving link.

    ``mass`` kg; ``com`` mm in the link frame; ``inertia`` = (ixx, iyy, izz, ixy, ixz, iyz) in kg.m^2,
    about the COM, in link-frame axes.
    """

    mass: float
    com: tuple[float, float, float]
    inertia: tuple[float, float, float, float, float, float]

    @property
    def com_m(self) -> np.ndarray:
        """Centre of mass in metres (link frame)."""
        return np.asarray(self.com, dtype=float) / 1000.0

    @property
    def inertia_matrix(self) -> np.ndarray:
        """Symmetric 3x3 inertia tensor about the COM (kg.m^2)."""
        ixx, iyy, izz, ixy, ixz, iyz = self.inertia
        return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


@dataclass(frozen=True)
class InertialSet:
    """Inertials of the moving links of one model, link 1 first."""

    name: str
    links: tuple[LinkInertial, ...]

    @property
    def total_mass(self) -> float:
        """Moving mass in kg (without the base link)."""
        return sum(link.mass for link in self.links)


def _l(mass: float, com: tuple[float, float, float],
       inertia: tuple[float, float, float, float, float, float]) -> LinkInertial:
    return LinkInertial(mass, com, inertia)


#: xArm5, set ``xarm5_type5_HT_BR2`` (vendor default).
XARM5_HT_BR2 = InertialSet("xarm5_type5_HT_BR2", (
    _l(2.3849, (0.13, 29.40, -12.39),
       (0.005705, 0.00489488, 0.00334846, 1.056e-05, -2.642e-05, -0.000890795)),
    _l(2.164, (37.88, -225.40, 34.47),
       (0.0278053, 0.00551739, 0.02692536, 0.0048865, 0.000656695, -0.00466808)),
    _l(2.121, (68.83, 229.85, 1.02),
       (0.0373639, 0.0058447, 0.0359236, -0.00417385, 0.00143647, 0.0075398)),
    _l(1.3169, (64.89, 31.22, 3.19),
       (0.00144315, 0.0018275, 0.00231563, -0.000455133, 0.000291878, 0.000132545)),
    _l(0.17, (0.0, -6.77, -10.98),
       (9.3e-05, 5.87e-05, 0.000132, 0.0, 0.0, -3.6e-06)),
))

#: xArm6, set ``xarm6_type6_HT_BR2`` (vendor default).
XARM6_HT_BR2 = InertialSet("xarm6_type6_HT_BR2", (
    _l(2.3814, (0.22, 29.51, -12.40),
       (0.0058562, 0.0050316, 0.003536652, -1.79e-05, 3.55e-06, -0.000888336)),
    _l(2.2675, (38.81, -227.83, 34.96),
       (0.028315776, 0.0058, 0.0273447, 0.005, 0.00066546, -0.0045741)),
    _l(1.875, (70.41, 116.31, 10.70),
       (0.0063483, 0.00379758, 0.00595768, -0.0015397, 0.00096858, 0.00186567)),
    _l(1.3192, (-0.18, 17.98, -22.91),
       (0.004896, 0.00445694, 0.00134332, -6.925e-06, -1.418e-05, -0.00023186)),
    _l(1.33854, (65.10, 30.96, 3.15),
       (0.00146378, 0.00184192, 0.002333524, -0.000450624, 0.000284306, 0.000130866)),
    _l(0.17, (0.0, -6.77, -10.98),
       (9.3e-05, 5.87e-05, 0.000132, 0.0, 0.0, -3.6e-06)),
))

#: xArm7, set ``xarm7_type7_HT_BR2`` (vendor default; also the MuJoCo menagerie xArm7 inertials).
XARM7_HT_BR2 = InertialSet("xarm7_type7_HT_BR2", (
    _l(2.382, (-0.20, 29.05, -12.33),
       (0.0056905, 0.0049566, 0.003316654, -1.579e-05, 5.125e-06, -0.000873378)),
    _l(1.869, (0.22, -128.56, 17.35),
       (0.0095989, 0.00382472, 0.007565669, 1.541e-06, 5.56e-06, -0.00317156)),
    _l(1.6383, (46.60, -24.63, -7.68),
       (0.00310955, 0.00264483, 0.0026624, 0.00030837, -0.00058453, 0.000338893)),
    _l(1.7269, (70.47, -115.75, 12.00),
       (0.005889, 0.00359703, 0.00543244, 0.00137112, 0.00088143, -0.001762155)),
    _l(1.3203, (-0.32, 16.04, -26.00),
       (0.00534665, 0.0049779, 0.0013624, 1.5117e-05, -3.69e-07, -0.00022132)),
    _l(1.325, (64.69, 32.78, 21.41),
       (0.0014745, 0.0019037, 0.0023652, -0.000488, 0.0002953, 0.00014749)),
    _l(0.17, (0.0, -6.77, -10.98),
       (9.3e-05, 5.87e-05, 0.000132, 0.0, 0.0, -3.6e-06)),
))

#: Lite 6, set ``xarm6_type9_HT_BR2`` (link 5 weighs 0.804 kg there; the D-H article prints 0.084).
LITE6_HT_BR2 = InertialSet("xarm6_type9_HT_BR2", (
    _l(1.411, (-0.36, 41.95, -2.5),
       (0.00145164, 0.0008873, 0.00131993, -1.24e-05, 6.7e-06, -0.0001255)),
    _l(1.34, (179.0, 0.0, 58.4),
       (0.0015854, 0.0056097, 0.00485, 6.766e-06, 0.00115136, -1.14e-06)),
    _l(0.953, (72.0, -35.7, -1.0),
       (0.0008861, 0.0015785, 0.00184677, 0.00039287, -7.066e-05, 2.445e-05)),
    _l(1.284, (-2.0, -28.5, -81.3),
       (0.003705, 0.0030455, 0.0015413, 2.0e-06, -7.17e-06, 0.00093188)),
    _l(0.804, (0.0, 10.0, 1.9),
       (0.0005668, 0.0005077, 0.00053, -6.0e-07, 5.3e-06, 4.8e-07)),
    _l(0.13, (0.0, -1.94, -10.2),
       (7.726e-05, 8.5665e-05, 0.00014814, -1.0e-06, -4.0e-07, 6.0e-07)),
))

#: UFACTORY 850, set ``xarm6_type12_HT_LDBR2``.
UF850_HT_LDBR2 = InertialSet("xarm6_type12_HT_LDBR2", (
    _l(4.807, (0.057, 13.842, -20.55),
       (0.022001729, 0.018900685, 0.012270188, -1.1152e-05, 6.738e-06, -0.000364084)),
    _l(3.28, (323.425, 0.095, 7.586),
       (0.007611984, 0.06420854, 0.0611757, -3.3561e-05, 0.008240021, -1.6145e-05)),
    _l(2.237, (128.834, 113.41, 9.78),
       (0.009920314, 0.008923236, 0.01428481, -0.005137841, 0.002628426, 0.002412869)),
    _l(2.041, (0.266, -38.33, -101.915),
       (0.019918597, 0.017515194, 0.004283807, -2.3185e-05, 5.8169e-05, 0.005878608)),
    _l(1.385, (0.057, -15.267, -1.015),
       (0.002077454, 0.001109183, 0.0020357, -5.026e-06, -6.99e-07, 6.747e-06)),
    _l(0.225, (0.484, -0.334, -14.217),
       (0.000130252, 0.000128308, 0.0002325, -4.285e-06, 3.19e-07, -3.86e-07)),
))

#: xArm 7T, set ``xarm7_type13_HT_BR2``.
XARM7T_HT_BR2 = InertialSet("xarm7_type13_HT_BR2", (
    _l(2.459, (0.13, -28.3, -13.0),
       (0.006061, 0.0052228, 0.00347077, -3.28e-06, -1.772e-05, 0.000924556)),
    _l(1.956, (-0.42, 126.07, 18.41),
       (0.01048, 0.0040914, 0.008267, 5.5459e-05, -3.9657e-05, 0.0034744)),
    _l(1.8618, (44.5, 21.12, -11.13),
       (0.0040936, 0.00368447, 0.00329033, -0.00039518, -0.000932, -0.0004827)),
    _l(1.8955, (67.74, 110.86, 12.7),
       (0.00724718, 0.00434535, 0.00680433, -0.0018978, 0.00117617, 0.00224485)),
    _l(1.428, (0.32, -14.93, -30.46),
       (0.00655938, 0.0061149, 0.00148845, 8.13e-06, 4.257e-06, 0.00036789)),
    _l(1.397, (65.0, -31.5, 4.2),
       (0.0016471, 0.00205013, 0.00258552, 0.00049082, 0.00034105, -0.00017778)),
    _l(0.1843, (0.0, 3.44, -10.34),
       (9.666e-05, 7.44e-05, 0.0001485, -2.7e-07, 0.0, 2.75e-06)),
))

#: Default inertial set by number of axes (the xArm 5, 6 and 7).
INERTIALS: dict[int, InertialSet] = {5: XARM5_HT_BR2, 6: XARM6_HT_BR2, 7: XARM7_HT_BR2}

#: Inertial set by model key (``RobotModel.key``).
INERTIALS_BY_MODEL: dict[str, InertialSet] = {
    "5": XARM5_HT_BR2, "6": XARM6_HT_BR2, "7": XARM7_HT_BR2,
    "lite6": LITE6_HT_BR2, "850": UF850_HT_LDBR2, "7t": XARM7T_HT_BR2,
}

#: Standard gravity used for all torques (m/s^2). The vendor does not state its value (9.8 and 9.81
#: differ by 0.1%); register 51 gives only a direction, scaled to this magnitude (``model.dynamics``).
STANDARD_GRAVITY = 9.81

# Joint sizes. ASSUMPTION (not published by UFACTORY): output-side torque constants (N.m per A of motor
# current, gear ratio included) of a frameless motor behind a ~1:100 harmonic drive, by joint size. They
# put the zero-pose holding currents of an xArm6 around 1.6 A (J2), 1.3 A (J3) and 0.8 A (J5).
TORQUE_CONSTANT_LARGE = 4.8  # shoulder joints J1, J2
TORQUE_CONSTANT_MEDIUM = 3.4  # elbow joint(s)
TORQUE_CONSTANT_SMALL = 1.2  # wrist joints

_SIZES: dict[int, tuple[str, ...]] = {
    5: ("L", "L", "M", "S", "S"),
    6: ("L", "L", "M", "S", "S", "S"),
    7: ("L", "L", "M", "M", "S", "S", "S"),
}
_KT = {"L": TORQUE_CONSTANT_LARGE, "M": TORQUE_CONSTANT_MEDIUM, "S": TORQUE_CONSTANT_SMALL}

# Lite 6 and 850. ASSUMPTION (the emulator's own, like the constants above): the Lite 6 runs one size
# smaller than the xArm 6 at the shoulder and elbow; the 850, whose shoulder carries about three times the
# xArm 6's gravity torque, runs twice the xArm's large constant at J1/J2 and the large one at its elbow.
_MODEL_SIZES: dict[str, tuple[str, ...]] = {
    "lite6": ("M", "M", "S", "S", "S", "S"),
    "850": ("L", "L", "L", "M", "S", "S"),
}
_MODEL_KT: dict[str, tuple[float, ...]] = {
    "850": (2.0 * TORQUE_CONSTANT_LARGE, 2.0 * TORQUE_CONSTANT_LARGE, TORQUE_CONSTANT_LARGE,
            TORQUE_CONSTANT_MEDIUM, TORQUE_CONSTANT_SMALL, TORQUE_CONSTANT_SMALL),
}

#: Nominal joint bus voltage (V). ASSUMPTION: the xArm 5/6/7 joints run from the control box's 48 V DC
#: arm supply; the rich report gives it x100 (manual 2.1.6, bytes 342-355).
NOMINAL_JOINT_VOLTAGE = 48.0


def joint_sizes(model: RobotModel | int) -> tuple[str, ...]:
    """Size class per joint: ``"L"`` (shoulder), ``"M"`` (elbow), ``"S"`` (wrist).

    A model picks its own (Lite 6, 850); a number of axes, or any other model, the xArm's for that many.
    """
    if not isinstance(model, int) and model.key in _MODEL_SIZES:
        return _MODEL_SIZES[model.key]
    dof = model if isinstance(model, int) else model.dof
    try:
        return _SIZES[int(dof)]
    except KeyError:
        raise ValueError(f"no xArm model with {dof!r} axes (expected 5, 6 or 7)") from None


def torque_constants(model: RobotModel | int) -> np.ndarray:
    """Assumed torque constant per joint (N.m/A), length ``dof``; current = torque / constant. A
    calibrated model (``RobotModel.calibration``) gives its measured constants instead."""
    cal = None if isinstance(model, int) else model.calibration
    if cal is not None and cal.torque_constants is not None:
        return np.array(cal.torque_constants, dtype=float)
    if not isinstance(model, int) and model.key in _MODEL_KT:
        return np.array(_MODEL_KT[model.key], dtype=float)
    return np.array([_KT[s] for s in joint_sizes(model)], dtype=float)


def get_inertials(model: RobotModel | int) -> InertialSet:
    """The inertial set of a model (by its key), or the xArm's default one for a number of axes."""
    if not isinstance(model, int) and model.key in INERTIALS_BY_MODEL:
        return INERTIALS_BY_MODEL[model.key]
    dof = model if isinstance(model, int) else model.dof
    try:
        return INERTIALS[int(dof)]
    except KeyError:
        raise ValueError(f"no inertial set for {dof!r} axes (expected 5, 6 or 7)") from None
