"""One JSON line per episode of a run's best checkpoint (deterministic, checking on): success, how
it ended, the door angle and the outcome of every subgoal ("b:" base, "a:" arm; "(R)" repeats the
previous action exactly; numbers replaced by #).

    python failure_traces.py RUN EPISODES FIRST_SEED > failure_traces_seedN.jsonl
"""
import json, re, sys
from pathlib import Path
from relmogen.experiments.evaluate import load_policy, policy_act, env_kwargs
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.rollout import run_episode

run, episodes, seed = Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
model, config, _ = load_policy(run, checkpoint="best")
env = RelmogenEnv(**env_kwargs(config, True, None, None, None))
act = policy_act(model, config, env)
for s in range(seed, seed + episodes):
    rec = run_episode(env, act, s)
    trace = [f"{g['subgoal_type'][0]}:{re.sub(r'[0-9][0-9.]*', '#', (g.get('reason') or 'ok').split(';')[-1].strip())[:28]}{'(R)' if g['repeat'] else ''}" for g in rec.subgoals]
    print(json.dumps({"seed": s, "success": rec.metrics.get("success"), "term": rec.termination, "steps": rec.steps,
                      "door": round(rec.metrics.get("door_angle_deg", 0), 1), "trace": trace}), flush=True)
