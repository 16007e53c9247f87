"""The end tools as bodies of the physics world: finger pads, the housing between flange and
fingers, the vacuum cup. Pure data in the flange frame (mm, N); no engine needed to read it.

The geometry is the emulator's estimate from the tools' outline sizes (no vendor collision model is
published in a form the emulator can read): the fingertips end at the tool's usual TCP offset along
flange +z (the built-in tool lengths of ``model/collision.py``), the fingers close along flange y.
"""

from __future__ import annotations

from dataclasses import dataclass

from ...model.collision import BUILTIN_TOOLS
from ..devices import bio_gripper, bio_gripper_g1
from ..devices.robotiq import ROBOTIQ_2F85, ROBOTIQ_2F140


@dataclass(frozen=True)
class Hand:
    """One end tool as physical bodies (flange frame, mm).

    ``stroke``: the opening between the pads' inner faces, fully open (0 is closed);
    ``pad_half``: half extents of one pad (x across the finger, y its thickness, z its length);
    ``tip``: where the pads end along flange z; ``housing``: centre z and half extents of the box
    between the flange and the fingers; ``force``: the most each finger presses (N), at the strongest
    setting; ``friction``: the pads' Coulomb coefficient; ``cup_radius``: a vacuum cup's (0: none).
    """

    name: str
    stroke: float
    pad_half: tuple[float, float, float]
    tip: float
    housing: tuple[float, tuple[float, float, float]]
    force: float
    friction: float = 1.0
    cup_radius: float = 0.0

    @property
    def pad_center_z(self) -> float:
        return self.tip - self.pad_half[2]


#: The xArm Gripper: 0..850 position pulses span an 85 mm opening (0.1 mm a pulse), fingertips at the
#: tool's 172 mm TCP offset; 30 N a finger is the emulator's estimate of its grip.
XARM_HAND = Hand("xArm Gripper", stroke=85.0, pad_half=(10.0, 4.0, 20.0), tip=BUILTIN_TOOLS[1][2],
                 housing=(60.0, (30.0, 55.0, 60.0)), force=30.0)
#: Millimetres of opening per xArm gripper position pulse (register 0x0702, 0..850).
XARM_MM_PER_PULSE = XARM_HAND.stroke / 850.0

#: The Robotiq 2F-85: its 85 mm stroke, fingertips at its 174 mm tool length; the force is set per
#: grip by its rFR register (controller/devices/robotiq.py), this is the most.
ROBOTIQ_2F85_HAND = Hand("Robotiq 2F-85", stroke=ROBOTIQ_2F85.stroke_mm, pad_half=(11.0, 4.0, 19.0),
                         tip=BUILTIN_TOOLS[4][2], housing=(55.0, (35.0, 60.0, 55.0)),
                         force=ROBOTIQ_2F85.force_max)

#: The Robotiq 2F-140: its 140 mm stroke, fingertips at its 244 mm tool length, a wider palm; the
#: force set per grip by rFR, this is the most.
ROBOTIQ_2F140_HAND = Hand("Robotiq 2F-140", stroke=ROBOTIQ_2F140.stroke_mm, pad_half=(13.0, 4.0, 24.0),
                          tip=BUILTIN_TOOLS[5][2], housing=(80.0, (35.0, 85.0, 80.0)),
                          force=ROBOTIQ_2F140.force_max)

#: The xArm Vacuum Gripper: a 20 mm cup whose face is at its 126 mm tool length.
VACUUM_HAND = Hand("xArm Vacuum Gripper", stroke=0.0, pad_half=(0.0, 0.0, 0.0), tip=BUILTIN_TOOLS[2][2],
                   housing=(50.0, (30.0, 30.0, 50.0)), force=0.0, cup_radius=20.0)

#: The BIO gripper: fingertips at its 150 mm tool length, opening 71..150 mm (its model keeps the
#: fingers within; the pads' joints span 0..150); 50 N a finger at force 100 is the emulator's estimate.
BIO_HAND = Hand("xArm BIO Gripper", stroke=bio_gripper.OPEN_MM, pad_half=(12.0, 4.0, 20.0),
                tip=BUILTIN_TOOLS[3][2], housing=(50.0, (40.0, 90.0, 50.0)), force=50.0)

#: The first-generation BIO gripper ("G1"): its positions 50..130 have no published millimetre scale,
#: and the device emulation (controller/devices/bio_gripper_g1.py) already reports them as the
#: opening (its ``opening_mm``, the width of an object between the fingers), so the engine takes one
#: unit for one millimetre: the pads open to 130 mm and close to 50 mm. The pads, the housing, the
#: fingertips at the BIO gripper's 150 mm tool length and 50 N a finger (the G1 has no force setting)
#: are the G2's estimates.
BIO_G1_HAND = Hand("xArm BIO Gripper G1", stroke=float(bio_gripper_g1.OPEN), pad_half=BIO_HAND.pad_half,
                   tip=BIO_HAND.tip, housing=BIO_HAND.housing, force=BIO_HAND.force)

#: The Lite 6 gripper (pneumatic jaws on TO0/TO1): each finger slides 8.1 mm, so the opening spans
#: 0..16.2 mm with the fingers fitted to close fully, and the fingertips end 81.1 mm from the flange
#: (the public MJCF of the Lite 6 gripper, derived from UFACTORY's URDF); 10 N a finger and the pad
#: and housing sizes are the emulator's estimates.
LITE6_HAND = Hand("Lite 6 Gripper", stroke=16.2, pad_half=(8.0, 3.0, 10.0), tip=81.1,
                  housing=(27.0, (25.0, 30.0, 27.0)), force=10.0)

#: The hands by the emulator's gripper names (``Emulator(gripper=...)``).
HANDS = {"xarm": XARM_HAND, "robotiq-2f85": ROBOTIQ_2F85_HAND, "robotiq-2f140": ROBOTIQ_2F140_HAND,
         "bio": BIO_HAND, "bio-g1": BIO_G1_HAND}
