import numpy as np
import pytest

from relmogen.tasks.terms import EventReward, PotentialReward, StateReward, spl


def test_spl_on_a_hand_made_trajectory():
    # shortest path 4 m; the robot drove a 1 m detour: SPL = 4 / 5
    trajectory = np.array([[0, 0], [2, 0], [2, 1], [2, 0], [4, 0]], dtype=float)
    driven = np.linalg.norm(np.diff(trajectory, axis=0), axis=1).sum()
    assert driven == pytest.approx(6.0)
    assert spl(True, 4.0, driven) == pytest.approx(4.0 / 6.0)
    assert spl(False, 4.0, driven) == 0.0
    assert spl(True, 4.0, 3.9) == 1.0  # never above 1
    assert spl(True, 0.0, 0.0) == 1.0


def test_potential_reward_pays_progress_and_charges_regress():
    values = iter([5.0, 4.0, 4.5, 0.0])
    current = {"v": next(values)}
    term = PotentialReward("geodesic", lambda: current["v"], weight=1.0)
    term.reset()
    rewards = []
    for v in values:
        current["v"] = v
        rewards.append(term())
    assert rewards == pytest.approx([1.0, -0.5, 4.5])


def test_event_reward_is_paid_once():
    state = {"done": False}
    term = EventReward("success", lambda: state["done"], 10.0)
    term.reset()
    assert term() == 0.0
    state["done"] = True
    assert [term(), term()] == [10.0, 0.0]


def test_state_reward_scales_the_value():
    term = StateReward("reach", lambda: 0.25, -1.0)
    assert term() == -0.25
