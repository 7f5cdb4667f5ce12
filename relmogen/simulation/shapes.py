"""Box collision shapes that can be read back, per body and link.

PyBullet cannot return the collision geometry of a body built with ``createMultiBody`` from
programmatic shapes (``getCollisionShapeData`` fails on them), and every collidable body of the
scenes and task objects is such a body made of boxes. Shapes made with ``box_collision_shape``
are recorded per (client, shape id), and ``record_body`` ties a body's base (link -1) and links to
them, so that ``body_boxes`` gives back each link's boxes in its link frame. Link pairs whose
contacts are turned off go through ``ignore_contacts``. The arm's C++ collision backend
(``relmogen.motion_generation.coal_collision``) builds its world from both.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import pybullet as p

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
IDENTITY: Quat = (0.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True)
class LocalBox:
    """A box in its link's frame (the URDF-style link frame, not the centre of mass)."""

    half_extents: Vec3
    position: Vec3 = (0.0, 0.0, 0.0)
    orientation: Quat = IDENTITY


_SHAPES: dict[tuple[int, int], tuple[LocalBox, ...]] = {}
_BODIES: dict[tuple[int, int], dict[int, tuple[LocalBox, ...]]] = {}
_BASE_INERTIAL: dict[tuple[int, int], Vec3] = {}
_IGNORED: dict[int, set[tuple[int, int, int, int]]] = {}  # client -> (body, link, body, link) without contacts
_CHANGES: dict[int, int] = {}  # client -> bodies recorded and pairs ignored so far


def box_collision_shape(client: int, half_extents: Sequence[Sequence[float]],
                        positions: Sequence[Sequence[float]] | None = None, compound: bool = False) -> int:
    """A collision shape of one box (``createCollisionShape``) or a compound of boxes
    (``createCollisionShapeArray``, also for one box with ``compound``), recorded; ``positions`` are
    the boxes' centres in the link frame."""
    halves = [tuple(float(v) for v in half) for half in half_extents]
    centres = [tuple(float(v) for v in centre) for centre in (positions or [(0.0, 0.0, 0.0)] * len(halves))]
    if len(halves) != len(centres) or not halves:
        raise ValueError(f"{len(halves)} boxes and {len(centres)} positions: give one position per box")
    if len(halves) == 1 and not compound:
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(halves[0]), collisionFramePosition=list(centres[0]),
                                       physicsClientId=client)
    else:
        shape = p.createCollisionShapeArray([p.GEOM_BOX] * len(halves), halfExtents=[list(h) for h in halves],
                                            collisionFramePositions=[list(c) for c in centres], physicsClientId=client)
    _SHAPES[(client, shape)] = tuple(LocalBox(h, c) for h, c in zip(halves, centres))
    return shape


def record_body(client: int, body: int, link_shapes: Mapping[int, int],
                base_inertial_position: Sequence[float] = (0.0, 0.0, 0.0)) -> int:
    """Ties ``body``'s links (-1 the base) to shapes made by ``box_collision_shape`` (-1: none),
    and keeps the ``baseInertialFramePosition`` it was made with (PyBullet poses a base by its
    centre of mass); returns ``body``."""
    _BODIES[(client, body)] = {link: _SHAPES[(client, shape)] for link, shape in link_shapes.items() if shape >= 0}
    _BASE_INERTIAL[(client, body)] = tuple(float(v) for v in base_inertial_position)
    _CHANGES[client] = _CHANGES.get(client, 0) + 1
    return body


def changes(client: int) -> int:
    """A count that grows with every ``record_body`` and ``ignore_contacts`` on ``client``: what
    was built from them is stale when it differs."""
    return _CHANGES.get(client, 0)


def base_inertial_position(client: int, body: int) -> Vec3:
    """The centre of mass in the base frame of a recorded body."""
    return _BASE_INERTIAL[(client, body)]


def body_boxes(client: int, body: int) -> dict[int, tuple[LocalBox, ...]] | None:
    """Each link's boxes (-1 the base), or None for a body not recorded here."""
    return _BODIES.get((client, body))


def forget_client(client: int) -> None:
    """Drops what was recorded for ``client`` (a new or closed connection reuses its id)."""
    for registry in (_SHAPES, _BODIES, _BASE_INERTIAL):
        for key in [key for key in registry if key[0] == client]:
            del registry[key]
    _IGNORED.pop(client, None)
    _CHANGES.pop(client, None)


def ignore_contacts(client: int, body_a: int, link_a: int, body_b: int, link_b: int) -> None:
    """No contacts between the two links (``setCollisionFilterPair``), recorded: a collision
    check that does not ask PyBullet for contacts must leave the pair out too."""
    p.setCollisionFilterPair(body_a, body_b, link_a, link_b, 0, physicsClientId=client)
    _IGNORED.setdefault(client, set()).update({(body_a, link_a, body_b, link_b), (body_b, link_b, body_a, link_a)})
    _CHANGES[client] = _CHANGES.get(client, 0) + 1


def contacts_ignored(client: int, body_a: int, link_a: int, body_b: int, link_b: int) -> bool:
    """Whether ``ignore_contacts`` turned the pair's contacts off."""
    return (body_a, link_a, body_b, link_b) in _IGNORED.get(client, ())
