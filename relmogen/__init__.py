"""relmogen: reinforcement learning with motion generation for mobile manipulation.

Importing the package registers the Gymnasium ids ``relmogen/<TaskName>-v0``.
"""

__version__ = "0.1.0"

from relmogen.envs import ENV_IDS  # noqa: E402,F401  (registers the environments)
