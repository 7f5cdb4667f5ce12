"""glibc's malloc thresholds for the learners' updates (``relmogen.agents.allocator``, issue 58)."""

import platform

import pytest

from relmogen.agents import allocator

pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture
def counted_calls(monkeypatch) -> list[None]:
    """A fresh process as far as ``keep_freed_memory_once`` can tell; each call of
    ``keep_freed_memory`` is appended (and nothing set in glibc)."""
    calls = []
    monkeypatch.setattr(allocator, "_kept_freed_memory", False)
    monkeypatch.setattr(allocator, "keep_freed_memory", lambda *args: calls.append(None) or True)
    return calls


def test_freed_memory_is_kept_under_glibc_and_can_be_asked_for_twice():
    kept = allocator.keep_freed_memory()
    assert isinstance(kept, bool)
    assert allocator.keep_freed_memory() is kept
    if platform.system() == "Linux" and platform.libc_ver()[0] == "glibc":
        assert kept


def test_keep_freed_memory_once_runs_once_per_process(counted_calls):
    allocator.keep_freed_memory_once()
    allocator.keep_freed_memory_once()
    assert len(counted_calls) == 1 and allocator._kept_freed_memory


def test_the_relmogen_d_learner_keeps_freed_memory_once_before_its_updates(model, counted_calls):
    model.learn(8)  # learning_starts 0, an update every 4 steps: two train calls
    assert model._n_updates == 2
    assert len(counted_calls) == 1


def test_the_allocator_bench_times_both_variants_in_forked_children():
    from relmogen.bench import train_bench

    kept = allocator._kept_freed_memory
    rows = train_bench.bench_qmap_update_allocator("PointNav", updates=1, rounds=1, preset="tiny")
    assert [row["variant"] for row in rows] == ["glibc_default", "keep_freed_memory"]
    assert all(row["update_cpu_s"] > 0 and row["page_faults_per_update"] >= 0 for row in rows)
    assert rows[0]["speedup_vs_glibc_default"] == 1.0 and rows[1]["speedup_vs_glibc_default"] > 0
    assert allocator._kept_freed_memory == kept  # put back
