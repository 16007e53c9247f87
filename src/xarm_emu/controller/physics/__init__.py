"""Objects, grasps and contacts: the physics world of a scene with ``[[object]]`` tables (their
declaration is controller/scene/objects.py) or cell elements (controller/scene/cell.py).

- ``hands.py``: the end tools as bodies (finger pads, housing), in the flange frame.
- ``mjcf.py``: the engine's model document from the project's own tables (joint frames, link
  capsules, inertials, hand, fixtures, objects).
- ``world.py``: the engine (MuJoCo, an optional extra) stepped by the control period, its state
  (:class:`~.world.PhysicsState`), object poses, placing.
- ``component.py``: the world as a controller component, coupling the gripper's fingers to it.
- ``driven.py``: grippers whose own model moves the fingers (Robotiq, BIO), through the fingers the
  device hands out (``ToolDevice.driven_fingers``), as the component asks.
- ``cell.py``: the scene's conveyors, sensors and feeders (controller/scene/cell.py) on the box's IO.

The engine is imported only by :func:`attach`, which the emulator calls for a scene with objects.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ...model.robots import RobotModel
    from ..scene.contact import Scene
    from .component import PhysicsComponent

#: What to install when the engine is missing.
INSTALL_HINT = "objects in a scene need the physics engine: pip install 'xarm-emu[physics]'"


def attach(model: RobotModel, scene: Scene, gripper: str, device: Any,
           vacuum: Any = None, io: Any = None, lite6: Any = None) -> PhysicsComponent:
    """The physics component of ``model`` with ``gripper`` (its tool-bus ``device``), or the vacuum
    gripper ``vacuum`` when attached, or the Lite 6 gripper's jaws ``lite6`` on an arm that has them
    with no other gripper named, in ``scene``, its cell elements on the box's IO module ``io``;
    ValueError with :data:`INSTALL_HINT` when the engine is not installed (ValueError: one line, as a
    bad scene file)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        raise ValueError(INSTALL_HINT) from None
    from .component import PhysicsComponent
    from .hands import HANDS, LITE6_HAND, VACUUM_HAND
    from .world import World

    jaws = lite6 if lite6 is not None and vacuum is None and gripper == "xarm" else None
    hand = VACUUM_HAND if vacuum is not None else LITE6_HAND if jaws is not None else HANDS.get(gripper)
    component = PhysicsComponent(World(model, scene, hand), None if jaws is not None else device, vacuum,
                                 lite6=jaws)
    component.attach_io(io)
    return component
