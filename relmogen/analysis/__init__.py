"""Analyses behind figures of README.md and docs/ that no other command prints: ``relmogen analyse``.

Each module is one topic; every function takes run folders, checkpoints, policies or the JSON
files other commands write, and returns plain rows (dicts) that ``relmogen analyse`` prints as a
Markdown table or JSON. The commands that produced each committed figure are in its
``results/<folder>/COMMANDS.md``.

- ``training``: episodes.csv and TensorBoard of runs, window by window, and their curves;
- ``validation``: choose a run's kept model on its periodic plus extra validation evaluations;
- ``checkpoints``: average the weights of a run's kept checkpoints;
- ``episodes``: per-episode traces of a policy (subgoal outcomes, failures) under other settings;
- ``subgoals``: where the base stood at arm subgoals (``relmogen viz subgoals`` JSONs);
- ``oracles``: the oracle table, and SGP-D's random exploration (epsilon = 1);
- ``arm``: the arm motion generator under ``ArmConfig`` settings (step cost, oracle figures, plans
  before a door, what an IK solution collides with);
- ``reach``: arm plans by distance, the reach mask against IK, button presses around the button;
- ``goal_pixels``: where a TabletopReachM policy's first arm subgoal lands against the marker in the image;
- ``qvalues``: a relmogen-d checkpoint's Q maps at oracle or greedy states, and the oracle-cell table;
- ``replay``: what a saved replay holds, and extra updates on it without new data.
"""
