"""Contact queries: which robot links touch the environment."""

from __future__ import annotations

from dataclasses import dataclass

import pybullet as p


@dataclass(frozen=True)
class Collision:
    robot_link: str
    other_body: int
    other_link: int
    distance: float = 0.0  # Bullet's contact distance: 0 touching, negative the penetration depth (m)

    def describe(self, client: int) -> str:
        name = p.getBodyInfo(self.other_body, physicsClientId=client)[1].decode() or f"body {self.other_body}"
        return f"robot link {self.robot_link!r} touched {name!r} (link {self.other_link})"


def robot_collisions(
    client: int,
    robot_id: int,
    link_names: dict[int, str],
    allowed_links: frozenset[int],
    floor_contact_links: frozenset[int],
    floor_body: int | None,
) -> list[Collision]:
    """Contacts of the robot with anything else, except the gripper (``allowed_links``) and
    the wheels/casters resting on the floor (``floor_contact_links`` against ``floor_body``).

    Bullet also reports points closer than its contact threshold (2 cm) that do not touch;
    only touching or penetrating points (distance <= 0) count."""
    result = []
    for contact in p.getContactPoints(bodyA=robot_id, physicsClientId=client):
        other, robot_link, other_link, distance = contact[2], contact[3], contact[4], contact[8]
        if distance > 0.0 or other == robot_id or robot_link in allowed_links:
            continue
        if other == floor_body and robot_link in floor_contact_links:
            continue
        result.append(Collision(link_names.get(robot_link, str(robot_link)), other, other_link, distance))
    return result


def robot_touches(client: int, robot_id: int, ignored_bodies: frozenset[int] = frozenset()) -> dict[int, tuple]:
    """Bodies the robot touches (any link, the gripper included; points at distance <= 0), except
    itself and ``ignored_bodies`` (e.g. the floor its wheels stand on): body id -> mean world
    position (x, y, z) of the touching points on that body."""
    points: dict[int, list] = {}
    for contact in p.getContactPoints(bodyA=robot_id, physicsClientId=client):
        other, distance = contact[2], contact[8]
        if distance > 0.0 or other == robot_id or other in ignored_bodies:
            continue
        points.setdefault(other, []).append(contact[6])
    return {body: tuple(sum(axis) / len(found) for axis in zip(*found)) for body, found in points.items()}
