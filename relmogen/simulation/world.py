"""One PyBullet physics client in DIRECT mode (no GUI, no GL) with the project's settings.

Every PyBullet call in relmogen passes ``physicsClientId`` explicitly, so several worlds can
live in one process and environments can be created in a parent and a child process alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import pybullet as p

from relmogen.simulation.shapes import forget_client

GRAVITY = -9.81


@dataclass(frozen=True)
class PhysicsSettings:
    time_step: float = 0.025  # paper Table A.6
    # Two sub-steps keep differential driving straight: with none, 1 s drives drifted up to
    # 0.24 rad off heading; with two, at most 0.06 rad (measured over 12 random drives).
    sub_steps: int = 2
    solver_iterations: int = 50


class World:
    """Owns a DIRECT PyBullet client; close() (or garbage collection) disconnects it."""

    def __init__(self, settings: PhysicsSettings | None = None):
        self.settings = settings or PhysicsSettings()
        self.client = p.connect(p.DIRECT)
        if self.client < 0:
            raise RuntimeError("could not start a PyBullet DIRECT client")
        forget_client(self.client)  # shapes recorded for an earlier connection with this id
        p.setGravity(0.0, 0.0, GRAVITY, physicsClientId=self.client)
        p.setPhysicsEngineParameter(
            fixedTimeStep=self.settings.time_step,
            numSubSteps=self.settings.sub_steps,
            numSolverIterations=self.settings.solver_iterations,
            deterministicOverlappingPairs=1,
            physicsClientId=self.client,
        )

    @property
    def time_step(self) -> float:
        return self.settings.time_step

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            p.stepSimulation(physicsClientId=self.client)

    def save_state(self) -> int:
        return p.saveState(physicsClientId=self.client)

    def restore_state(self, state_id: int) -> None:
        p.restoreState(stateId=state_id, physicsClientId=self.client)

    def remove_state(self, state_id: int) -> None:
        p.removeState(state_id, physicsClientId=self.client)

    def close(self) -> None:
        if self.client is not None and p.isConnected(self.client):
            p.disconnect(self.client)
            forget_client(self.client)
        self.client = None

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown: pybullet may already be gone
            pass
