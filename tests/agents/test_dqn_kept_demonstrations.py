"""relmogen-d's kept demonstrations (``relmogen/agents/addons/kept_demonstrations.py``): the ring skips them."""

import pytest
from dqn_helpers import add_rows, tiny_buffer

from relmogen.agents.dqn import QMapReplayBuffer


@pytest.mark.parametrize("keep", [True, False])
def test_the_ring_skips_kept_demonstration_rows(keep):
    buffer = tiny_buffer(8, keep)
    add_rows(buffer, [20, 21, 22], demonstrations=True)
    add_rows(buffer, range(10), demonstrations=False)  # 10 policy rows wrap the 8-row ring
    stored = buffer.actions[:, 0, 0].astype(int).tolist()
    if keep:
        assert stored == [20, 21, 22, 5, 6, 7, 8, 9] and buffer.demo.tolist() == [True] * 3 + [False] * 5
        add_rows(buffer, [10], demonstrations=False)
        assert buffer.full and buffer.actions[3, 0, 0] == 10  # the next row goes after the demonstrations
    else:
        assert stored == [5, 6, 7, 8, 9, 2, 3, 4] and not buffer.demo.any()
    add_rows(buffer, [23], demonstrations=True)  # a resume's extra demonstrations are kept as well
    assert buffer.demo.sum() == (4 if keep else 1)


def test_demonstrations_filling_the_whole_ring_are_refused():
    buffer = tiny_buffer(4, keep=True)
    add_rows(buffer, range(4), demonstrations=True)
    with pytest.raises(ValueError, match="demonstrations fill all 4 rows"):
        add_rows(buffer, [5], demonstrations=False)


def test_a_buffer_saved_before_demonstration_rows_loads_with_none():
    buffer = tiny_buffer(4, keep=False)
    state = dict(vars(buffer))  # such buffers also predate pickling only the filled rows
    for key in ("demo", "keep_demonstrations", "adding_demonstrations", "acting_masks", "labels", "acting_labels"):
        state.pop(key)
    old = QMapReplayBuffer.__new__(QMapReplayBuffer)
    old.__setstate__(dict(state))
    assert old.demo.shape == (4,) and not old.demo.any() and not old.keep_demonstrations
    assert (old.labels == -1).all()
    add_rows(old, [1], demonstrations=False)
