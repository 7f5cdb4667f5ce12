import pytest

from relmogen.envs.relmogen_env import RelmogenEnv


@pytest.fixture(scope="module")
def pointnav():
    env = RelmogenEnv(task="PointNav", control="joint", image_size=64)
    yield env
    env.close()
