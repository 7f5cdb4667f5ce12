"""Suite-wide settings for speed (issue 55: the suite stays under 4 minutes on an idle machine)."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def one_torch_thread_per_process():
    """One torch (OpenMP) thread per test process: ``scripts/test.sh`` runs two xdist workers on a
    2-core machine, and two threads each thrash it (tests that time torch pick their own)."""
    import torch as th  # here, not at the top: the xdist controller loads this file but runs no test

    threads = th.get_num_threads()
    th.set_num_threads(1)
    yield
    th.set_num_threads(threads)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """``--dist loadgroup`` (scripts/test.sh) again sends the tests of one ``xdist_group`` (the
    Ray ones) to one worker, as one unit scheduled first.

    xdist 3.8 tells its scheduler the group by appending ``@group`` to ``item._nodeid``; pytest
    9.2 keeps node ids in ``item._id`` instead, so the suffix is lost and the tests are spread
    over both workers (pytest-dev/pytest-xdist#1386, fix pending in #1388). This sets it the new
    way; it does nothing where xdist's own suffix took effect, or outside an xdist worker."""
    if not getattr(config.option, "loadgroup", False):
        return
    try:
        from _pytest.nodeid import NodeId
    except ImportError:  # pytest < 9.2: xdist's suffix works
        return
    for item in items:
        names = sorted({str(mark.args[0] if mark.args else mark.kwargs.get("name", "default"))
                        for mark in item.iter_markers("xdist_group")})
        suffix = f"@{'_'.join(names)}"
        if names and not item.nodeid.endswith(suffix) and isinstance(getattr(item, "_id", None), NodeId):
            item._id = NodeId.parse(item.nodeid + suffix)
