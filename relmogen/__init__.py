"""relmogen: reinforcement learning with motion generation for mobile manipulation.

Importing the package registers the Gymnasium ids ``relmogen/<TaskName>-v0``.
"""

__version__ = "0.1.0"

import ctypes
import os
import sys


def _import_pybullet_silently() -> None:
    """Import pybullet with the process's file descriptors 1 and 2 pointed at /dev/null: its C
    extension prints a "pybullet build time: ..." banner at import that no command wants. The C
    streams are flushed before the descriptors come back, so a buffered banner is dropped too."""
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    try:
        saved = [os.dup(fd) for fd in (1, 2)]
    except OSError:  # no descriptors to redirect (a detached process): import as is
        import pybullet  # noqa: F401

        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in (1, 2):
            os.dup2(devnull, fd)
        import pybullet  # noqa: F401
    finally:
        ctypes.CDLL(None).fflush(None)
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


_import_pybullet_silently()

from relmogen.envs import ENV_IDS  # noqa: E402,F401  (registers the environments)


def load(path, checkpoint: str = "latest", device: str = "auto"):
    """A trained policy with the environment settings of its run: ``path`` is a run directory
    (``checkpoint``: ``latest``, ``best`` or a checkpoint folder), a checkpoint folder or an
    exported actor's folder (``relmogen export``; e.g. ``relmogen/policies/PushDoorNav-relmogen-r``).
    The result's ``make_env()`` is ``gym.make(env_id, **env_kwargs)``, the environment ``relmogen
    eval`` builds for it, and ``policy(env)`` its greedy ``obs -> action`` in that environment
    (``relmogen.experiments.loading.TrainedPolicy``)."""
    from relmogen.experiments.loading import load_trained  # imported on use: `import relmogen` stays light

    return load_trained(path, checkpoint, device)
