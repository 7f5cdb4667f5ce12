"""How far each checkpoint's deterministic subgoal is from what it samples: on 1,000 observations
drawn from a replay buffer, per action dimension, the share of deterministic actions beyond 0.99
(tanh saturation), the median |mean| and the median standard deviation before the tanh.

    python actor_spread.py REPLAY.pkl RUN:best RUN:latest ... > actor_spread.txt
"""
import sys, numpy as np, torch as th
from pathlib import Path
from stable_baselines3.common.save_util import load_from_pkl
from relmogen.experiments.evaluate import load_policy
replay = load_from_pkl(sys.argv[1])
n = replay.size() if not replay.full else replay.buffer_size
rng = np.random.default_rng(0)
idx = rng.integers(0, n, 1000)
env_idx = rng.integers(0, replay.n_envs, 1000)
for spec in sys.argv[2:]:
    run, ck = spec.split(":")
    model, config, _ = load_policy(Path(run), checkpoint=ck)
    obs = {k: v[idx, env_idx] for k, v in replay.observations.items()}
    obs_t, _ = model.policy.obs_to_tensor(obs)
    with th.no_grad():
        mean, log_std, _ = model.actor.get_action_dist_params(obs_t)
    a = np.tanh(mean.numpy())
    print(f"{Path(run).parent.name}/{Path(run).name[:28]}", ck, "sat>0.99 per dim", np.round((np.abs(a) > 0.99).mean(0), 2), "|mean| median", np.round(np.median(np.abs(mean.numpy()), 0), 1), "std median", np.round(np.median(np.exp(log_std.numpy()), 0), 2), flush=True)
