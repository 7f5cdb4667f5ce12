"""Typed training configuration: YAML presets validated by pydantic, overridable per key.

A preset (``relmogen/configs/presets/<name>.yaml``) has three sections: ``env``, ``algos``
(one block per algorithm) and ``run``. ``resolve_config`` picks the block of the chosen
algorithm, applies ``--set section.key=value`` overrides and returns a ``TrainConfig`` that is
saved next to the run (``config.yaml``) so a run can always be resumed or reproduced.

Each algorithm has its model of ``algo.`` keys (``CONFIG_OF_ALGO``), all sharing ``AlgoConfig``'s
keys; a key of another algorithm is refused in one line naming the algorithms that have it. A key
a resumed run may change is a ``resumable`` field. ``read_config`` also reads ``config.yaml`` files
written when one flat model held every algorithm's keys (``with_algorithms_keys_only``).
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Literal, get_args

import yaml
from pydantic import (BaseModel, ConfigDict, Field, SerializeAsAny, ValidationError, ValidationInfo, field_validator,
                      model_validator)

PRESET_DIR = Path(__file__).resolve().parent.parent / "configs" / "presets"
Algo = Literal["relmogen-r", "relmogen-d", "sac", "oac", "hrl4in"]
ALGOS = get_args(Algo)
IMAGE_ONLY_ALGOS = {"relmogen-d": "its Q maps are over the camera image's pixels",
                    "hrl4in": "its encoder is the image encoder of SGP-R"}
CONTROL_OF_ALGO = {"relmogen-r": "subgoal-r", "relmogen-d": "subgoal-d", "sac": "joint", "oac": "joint",
                   "hrl4in": "joint"}


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class EnvConfig(_Strict):
    image_size: int = Field(128, ge=16)
    n_envs: int = Field(1, ge=1)
    scene: str | None = None
    base_planner: str = "rrt_connect"
    arm_planner: str = "rrt_connect"
    arm_collision_train: bool = False
    episode_steps: int | None = Field(None, ge=1)  # None: the paper's (25 subgoals / 750 joint steps)
    push_frame: Literal["base", "surface"] = "base"  # relmogen-d's push bins (subgoal_controls.py; ours: surface)
    # relmogen-d's arm-cell reach mask: "sphere" (spec.arm_reach around the first arm joint) or
    # "measured" (ours: the robot's reachability map, relmogen/robots/reachability.py)
    reach_mask: Literal["sphere", "measured"] = "sphere"
    # relmogen-d's Q-map side; None: image_size / 4 (the paper's 32 at 128 px). 2, 4 or 8 times it = image_size
    qmap_size: int | None = Field(None, ge=1)
    # a base subgoal whose goal pose is in collision: "strict" is a no-op (the paper's),
    # "nearest_free" drives to the nearest free pose toward it, "nearest_reachable" to the nearest
    # pose toward it that is free and connected to the robot on the local map (ours; base_planner.py)
    base_goal: Literal["strict", "nearest_free", "nearest_reachable"] = "strict"
    # m a base goal pose keeps from obstacles beyond the footprint, like a navigation stack's
    # inflation (ours; 0 is the paper's): the base cannot park where the arm has no room to push
    base_goal_clearance: float = Field(0.0, ge=0, le=1.0)
    noop_cost: float = Field(0.0, ge=0)  # subgoal controls: reward -cost for a subgoal that executed nothing (ours)
    # relmogen-r and relmogen-d: observe the previous subgoal and whether it executed nothing (ours; relmogen-d
    # draws its cell into two more local_map channels; subgoal_controls.py)
    subgoal_feedback: bool = False
    # subgoal controls: (iterations, restarts) of the arm's RRT-Connect; (20, 2) is the paper's
    # planner budget. (100, 4) turned most of the shipped policy's "no arm plan" subgoals into plans
    # (1.4 -> 0.3 per episode) for +1 CPU s per episode (results/pushdoornav-mg/)
    arm_rrt: tuple[int, int] = (20, 2)
    # subgoal controls: who answers the arm's collision queries inside IK solves and plans: coal (Pinocchio
    # + Coal in C++, ~5x cheaper checks; motion_generation/coal_collision.py; ArmConfig) or pybullet
    arm_collision_backend: Literal["pybullet", "coal"] = "coal"
    robot: str = "fetch"  # the embodiment: a folder of relmogen/robots/assets with a spec.yaml (fetch, movo)
    # rgbd: camera, LiDAR and task vector (the paper's); state: one low-dimensional vector of robot pose,
    # task vector and task-object poses (RelmogenEnv's obs_mode), for relmogen-r, sac and oac
    obs_mode: Literal["rgbd", "state"] = "rgbd"
    # The paper's fine-tuning to a new scene (appendix, PushDoorNav Scene-A -> Scene-B): the last
    # round(second_scene_fraction x n_envs) training environments run in second_scene (a scene
    # name, e.g. office_B), the others in `scene`; evaluation uses `scene` (or eval --scene).
    second_scene: str | None = None
    second_scene_fraction: float = Field(0.5, gt=0, le=1)

    @model_validator(mode="after")
    def _qmap_divides_the_image(self) -> EnvConfig:
        if self.qmap_size is not None and self.image_size not in (2 * self.qmap_size, 4 * self.qmap_size,
                                                                  8 * self.qmap_size):
            raise ValueError(f"env.qmap_size {self.qmap_size} needs env.image_size 2, 4 or 8 times it, "
                             f"got {self.image_size}")
        return self

    @field_validator("arm_rrt")
    @classmethod
    def _arm_rrt_positive(cls, arm_rrt: tuple[int, int]) -> tuple[int, int]:
        if min(arm_rrt) < 1:
            raise ValueError(f"env.arm_rrt is (iterations, restarts), both >= 1, got {list(arm_rrt)}")
        return arm_rrt

    @field_validator("robot")
    @classmethod
    def _robot_has_assets(cls, robot: str) -> str:
        from relmogen.robots.spec import available_robots

        robots = available_robots()
        if robot not in robots:
            raise ValueError(f"unknown robot {robot!r}; robots (folders of relmogen/robots/assets with a spec.yaml): "
                             f"{', '.join(robots)}")
        return robot

    @property
    def second_scene_envs(self) -> int:
        """How many training environments (the last ones) run in ``second_scene``."""
        return 0 if self.second_scene is None else int(math.floor(self.second_scene_fraction * self.n_envs + 0.5))

    @model_validator(mode="after")
    def _second_scene_gets_environments(self) -> EnvConfig:
        second = self.second_scene_envs
        if self.second_scene is not None and (second == 0 or (second == self.n_envs and self.second_scene_fraction < 1)):
            raise ValueError(f"env.second_scene {self.second_scene}: env.second_scene_fraction "
                             f"{self.second_scene_fraction} of env.n_envs {self.n_envs} puts {second} environments "
                             "there, leaving one scene without any; raise env.n_envs (the paper swaps half of its "
                             "training environments) or set the fraction to 1")
        return self


RESUMABLE = {"resumable": True}


def resumable(default, **constraints):
    """A field a resumed run may change (``--resume --set``): the learning schedule or the budget,
    not what fixes the network's shapes, the replay layout or the task, which a checkpoint cannot follow."""
    return Field(default, json_schema_extra=RESUMABLE, **constraints)


def resumable_keys(model: type[BaseModel]) -> list[str]:
    """The fields of ``model`` made with ``resumable``."""
    return [key for key, field in model.model_fields.items() if field.json_schema_extra == RESUMABLE]


class AlgoConfig(_Strict):
    """The keys of every algorithm (SB3's off-policy learners); ``CONFIG_OF_ALGO`` has each one's model."""

    learning_rate: float = resumable(3e-4, gt=0)
    buffer_size: int = resumable(10_000, ge=1)
    batch_size: int = resumable(256, ge=1)
    tau: float = resumable(0.005, gt=0, le=1)
    gamma: float = resumable(0.99, gt=0, le=1)
    learning_starts: int = resumable(200, ge=0)
    train_freq: int = resumable(1, ge=1)
    gradient_steps: int = resumable(1, ge=1)
    # task-oracle episodes put in the replay before learning (ours; 0 = off): subgoal policies only
    demo_episodes: int = resumable(0, ge=0)


class SACConfig(AlgoConfig):
    """relmogen-r and sac: SB3's SAC with the SGP-R encoder (agents/sac.py)."""

    net_arch: list[int] = Field(default_factory=lambda: [256, 256])
    ent_coef_init: float = Field(1.0, gt=0)  # the learned entropy temperature starts here (SB3's "auto": 1.0)
    ent_coef_min: float = Field(0.0, ge=0)  # floor under the learned temperature; 0 = none (SB3)
    target_entropy: float | None = None  # None = SB3's -dim(A)
    image_shift: int = Field(0, ge=0)  # DrQ's random shift of the images in each batch (pixels; 0 = off)
    image_encoder: Literal["paper", "keypoints"] = "paper"  # keypoints: agents/keypoints.py (ours)
    critic_layer_norm: bool = False  # LayerNorm in the critics' hidden layers (RLPD; agents/addons/critic_layer_norm.py)


class OACConfig(SACConfig):
    """oac: SAC with optimistic exploration (Ciosek et al. 2019; their MuJoCo settings by default)."""

    beta_ub: float = 4.66
    delta: float = 23.53


class DQNConfig(AlgoConfig):
    """relmogen-d's masked Double DQN and its Q-map network (agents/dqn.py); None: RelmogenDQN's
    or the network's default."""

    target_update_interval: int | None = resumable(None, ge=1)
    max_grad_norm: float | None = resumable(None, gt=0)
    exploration_initial_eps: float | None = resumable(None, ge=0, le=1)
    exploration_final_eps: float | None = resumable(None, ge=0, le=1)
    exploration_steps: int | None = resumable(None, ge=1)  # linear epsilon decay length (our choice)
    mask_arm: bool | None = None  # mask arm pixels without depth or beyond reach (default on; our choice)
    qmap_widths: list[int] | None = None
    qmap_head_width: int | None = None
    qmap_skip: bool | None = None  # S/4 branch features into the Q-map head (U-Net style; ours, default off)
    qmap_unet: bool | None = None  # a U-Net Q-map head: branch features at every scale (ours, default off; not with qmap_skip)
    qmap_bf16: bool | None = None  # the Q-map network under bfloat16 autocast but its last layer (ours, default off)
    qmap_head_kernel: Literal[4, 2] | None = None  # the Q-map head's last upsampling kernel: 4 (the paper's) or 2 (ours)


class DQNAddOns(_Strict):
    """relmogen-d's research add-ons (relmogen/agents/addons), all ours and off by default."""

    conservative_weight: float | None = resumable(None, ge=0)  # CQL-style term on untried actions; 0 = off
    demo_keep: bool = False  # the replay never overwrites the demonstrations
    demo_margin_weight: float = resumable(0.0, ge=0)  # DQfD's large-margin term on them (0 = off)
    n_step_returns: int | None = resumable(None, ge=1, le=25)  # n-step TD targets (DQfD, Rainbow); 1 = off
    oracle_labels: bool = resumable(False)  # the margin term on the oracle's labels of policy states
    exploration_temperature: float | None = resumable(None, ge=0)  # explore by softmax(Q / T); 0 = uniform
    priority_alpha: float | None = resumable(None, ge=0, le=1)  # prioritized replay's exponent; 0 = uniform
    priority_beta: float | None = resumable(None, ge=0, le=1)  # its first importance exponent, to 1 over exploration_steps
    shift_cells: int | None = resumable(None, ge=0)  # arm pushes' images and cells shifted up to this many cells (0 = off)


class RelmogenDConfig(DQNAddOns, DQNConfig):
    """relmogen-d: the masked Double DQN with its add-ons (keys in that order: common, DQN, add-ons)."""

    @model_validator(mode="after")
    def _one_qmap_head(self) -> RelmogenDConfig:
        if self.qmap_skip and self.qmap_unet:
            raise ValueError("algo.qmap_skip and algo.qmap_unet are two Q-map heads: choose one")
        return self

    @model_validator(mode="after")
    def _demonstration_terms_need_demonstrations(self) -> RelmogenDConfig:
        uses = [key for key in ("demo_keep", "demo_margin_weight") if getattr(self, key)]
        uses = [key for key in uses if not (key == "demo_margin_weight" and self.oracle_labels)]
        if uses and not self.demo_episodes:
            raise ValueError(f"{' and '.join(uses)}: these act on demonstrations; set algo.demo_episodes too")
        if self.oracle_labels and not self.demo_margin_weight:
            raise ValueError("oracle_labels act through the margin term: set algo.demo_margin_weight > 0 too")
        return self


class HRL4INConfig(SACConfig):
    """hrl4in (Li et al. 2020; relmogen/agents/hrl4in.py): the SAC keys train its low level, the
    hrl4in_high_* keys its high level."""

    hrl4in_k: int = Field(30, ge=1)  # most low-level steps per subgoal (HRL4IN's time_scale)
    hrl4in_embodiments: list[Literal["base", "arm", "both"]] = Field(default_factory=lambda: ["base", "arm", "both"],
                                                                     min_length=1)
    hrl4in_base_range: float = Field(1.0, gt=0)  # base subgoal offsets in [-range, range] m, robot frame
    hrl4in_ee_range: float = Field(0.5, gt=0)  # end-effector subgoal offsets, m
    hrl4in_tolerance: float = Field(0.1, gt=0)  # achieved: every masked-in component within this (m)
    hrl4in_progress_scale: float = Field(30.0, ge=0)  # intrinsic reward per metre of progress
    hrl4in_distance_weight: float = Field(0.0, ge=0)  # intrinsic -weight * remaining distance (m)
    hrl4in_success_bonus: float = Field(0.0, ge=0)  # intrinsic bonus when a subgoal is achieved
    hrl4in_mask_penalty: float = Field(0.0, ge=0)  # intrinsic -weight * sum of squared masked actions
    hrl4in_extrinsic_weight: float = 0.0  # share of the task reward the low level also gets
    hrl4in_high_learning_rate: float | None = Field(None, gt=0)  # None: learning_rate
    hrl4in_high_gamma: float = Field(0.99, gt=0, le=1)  # per subgoal
    hrl4in_high_buffer_size: int = Field(10_000, ge=1)  # high-level transitions (one per subgoal)
    hrl4in_high_batch_size: int | None = Field(None, ge=1)  # None: batch_size
    hrl4in_high_learning_starts: int = Field(50, ge=0)  # high-level transitions of random subgoals first


CONFIG_OF_ALGO: dict[str, type[AlgoConfig]] = {"relmogen-r": SACConfig, "sac": SACConfig, "oac": OACConfig,
                                               "relmogen-d": RelmogenDConfig, "hrl4in": HRL4INConfig}


def algos_with_key(key: str) -> list[str]:
    return [algo for algo, model in CONFIG_OF_ALGO.items() if key in model.model_fields]


def unknown_algo_key(key: str, algo: str, prefix: str = "algo.") -> str | None:
    """None when ``algo`` has ``key``; else one line saying which algorithms have it or, for a key
    none has, the nearest key ``algo`` has."""
    fields = CONFIG_OF_ALGO[algo].model_fields
    if key in fields:
        return None
    owners = algos_with_key(key)
    if owners:
        return f"{prefix}{key}: {', '.join(owners)} only, not {algo}"
    return unknown_key(key, fields, prefix)


def unknown_key(key: str, fields, prefix: str) -> str | None:
    return None if key in fields else f"unknown key {prefix}{key}{did_you_mean(key, fields, prefix)}"


def unknown_setting(section: str, key: str, algo: str | None = None, prefix: str | None = None) -> str | None:
    """None when ``section.key`` (section env, run, or algo of an ``algo`` run) is a setting; else
    why not, in one line, with the key spelled ``{prefix}{key}`` (default ``{section}.{key}``)."""
    prefix = f"{section}." if prefix is None else prefix
    if section == "algo":
        return unknown_algo_key(key, algo, prefix)
    return unknown_key(key, {"env": EnvConfig, "run": RunSettings}[section].model_fields, prefix)


class RunSettings(_Strict):
    eval_every_episodes: int = Field(100, ge=1)
    eval_episodes: int = Field(10, ge=1)
    # Seed of the periodic evaluations' first episode. None: 10000 + the training episode, a new block
    # each time. A number: the same block every time (a fixed validation set), so that "best"
    # compares checkpoints on the same episodes instead of picking whichever block was easy.
    eval_seed: int | None = Field(None, ge=0)
    # Keep the model of every periodic evaluation (checkpoints/evaluated_<episode>, ~19 MB each at
    # 64 px), so that a checkpoint can be chosen afterwards on a larger validation block.
    keep_evaluated: bool = False
    checkpoint_every_episodes: int = Field(20, ge=1)  # the model
    replay_every_episodes: int | None = Field(None, ge=1)  # the replay buffer: a multiple of the above; None = same
    # One learner thread: on a 2-core machine shared with the environment workers, two torch
    # threads made updates about 2.4x slower (measured under load).
    torch_threads: int = Field(1, ge=1)
    # n_envs > 1: the longest wait for one reply of an environment worker before the run stops with a
    # checkpoint (a subgoal plans and executes in seconds; a worker silent this long is stuck)
    worker_timeout_s: float = Field(600.0, gt=0)

    @model_validator(mode="after")
    def _replay_saved_with_a_model(self) -> RunSettings:
        if self.replay_every_episodes is None:
            self.replay_every_episodes = self.checkpoint_every_episodes
        if self.replay_every_episodes % self.checkpoint_every_episodes:
            raise ValueError(f"run.replay_every_episodes ({self.replay_every_episodes}) must be a multiple of "
                             f"run.checkpoint_every_episodes ({self.checkpoint_every_episodes})")
        return self


class TrainConfig(_Strict):
    task: str
    algo: Algo
    seed: int = 0
    preset: str = "cpu"
    episodes: int = resumable(1000, ge=1)
    max_hours: float | None = resumable(None, gt=0)  # stop on wall-clock instead (equal-time comparisons)
    # stop on CPU time of trainer plus workers (relmogen sweep --cpu-hours: fair when runs share machines)
    max_cpu_hours: float | None = resumable(None, gt=0)
    device: str = "auto"
    env: EnvConfig = Field(default_factory=EnvConfig)
    # the model of the run's algorithm (CONFIG_OF_ALGO), validated by _the_algorithms_model
    algo_params: SerializeAsAny[AlgoConfig] = Field(default_factory=dict, validate_default=True)
    run: RunSettings = Field(default_factory=RunSettings)

    @field_validator("algo_params", mode="wrap")
    @classmethod
    def _the_algorithms_model(cls, value, handler, info: ValidationInfo) -> AlgoConfig:
        model = CONFIG_OF_ALGO.get(info.data.get("algo"))
        if model is None:  # an unknown algorithm, refused on its own
            return handler(value)
        if type(value) is model:
            return value
        return model.model_validate(value.model_dump() if isinstance(value, BaseModel) else value)

    @property
    def control(self) -> str:
        return CONTROL_OF_ALGO[self.algo]

    @property
    def oracle_labels(self) -> bool:
        """Whether the environments label each state with the task oracle's choice (relmogen-d's add-on)."""
        return isinstance(self.algo_params, RelmogenDConfig) and self.algo_params.oracle_labels

    @model_validator(mode="after")
    def _demonstrations_need_subgoals(self) -> TrainConfig:
        if self.algo_params.demo_episodes and self.control == "joint":
            raise ValueError(f"demo_episodes needs a subgoal policy (relmogen-r or relmogen-d), not {self.algo}: "
                             "the task oracles act through subgoals")
        return self

    @model_validator(mode="after")
    def _oracle_labels_need_an_oracle(self) -> TrainConfig:
        if not self.oracle_labels:
            return self
        from relmogen.agents.oracles import ORACLES

        if self.task not in ORACLES:
            raise ValueError(f"oracle_labels: no oracle for task {self.task!r}; oracles exist for: "
                             f"{', '.join(sorted(ORACLES))}")
        return self

    @model_validator(mode="after")
    def _state_observations_need_a_vector_policy(self) -> TrainConfig:
        if self.env.obs_mode == "state" and self.algo in IMAGE_ONLY_ALGOS:
            raise ValueError(f"env.obs_mode=state: {self.algo} needs images ({IMAGE_ONLY_ALGOS[self.algo]}); "
                             "use relmogen-r, sac or oac")
        return self

    @model_validator(mode="after")
    def _feedback_stays_with_the_image(self) -> TrainConfig:
        if (self.env.subgoal_feedback and isinstance(self.algo_params, RelmogenDConfig)
                and self.algo_params.shift_cells):
            raise ValueError("env.subgoal_feedback with algo.shift_cells: the shift moves the camera image but not "
                             "the previous arm subgoal's cell drawn in local_map; use one of them")
        return self


def available_presets() -> list[str]:
    return sorted(path.stem for path in PRESET_DIR.glob("*.yaml"))


PRESET_SECTIONS = ("env", "algos", "run")


def is_preset_file(preset: str) -> bool:
    """Whether ``preset`` names a YAML file (a ``.yaml``/``.yml`` suffix or a folder in it) rather
    than a preset of ``relmogen/configs/presets``."""
    return preset.endswith((".yaml", ".yml")) or len(Path(preset).parts) > 1


def preset_path(preset: str) -> Path:
    """The YAML file of a preset name or of a preset file path (made absolute)."""
    if is_preset_file(preset):
        path = Path(preset).expanduser().resolve()
        if not path.is_file():
            raise ValueError(f"preset file {preset} does not exist; give an existing YAML file or a preset name "
                             f"({', '.join(available_presets())})")
        return path
    path = PRESET_DIR / f"{preset}.yaml"
    if not path.is_file():
        raise ValueError(f"unknown preset {preset!r}; valid presets: {', '.join(available_presets())} "
                         "(or the path of a YAML file)")
    return path


def recorded_preset(preset: str) -> str:
    """How a run's ``config.yaml`` names its preset: the name, or the absolute path of its file."""
    return str(preset_path(preset)) if is_preset_file(preset) else preset


def did_you_mean(name: str, valid, prefix: str = "") -> str:
    """``"; did you mean {prefix}X?"`` for the valid name X nearest ``name``, or ``""``: difflib's
    closest match among the names and their heads (so ``evl_every`` finds ``eval_every_episodes``)."""
    valid = [str(option) for option in valid]
    heads: dict[str, str] = {}
    for option in valid:
        heads.setdefault(option[:len(name) + 1], option)
    close = difflib.get_close_matches(name, valid + list(heads), n=1)
    if not close:
        return ""
    return f"; did you mean {prefix}{close[0] if close[0] in valid else heads[close[0]]}?"


def load_preset(preset: str) -> dict:
    """The sections of a preset, given by name or as a YAML file path (``is_preset_file``); an
    unknown section, algorithm block or key is a ValueError naming the nearest valid one."""
    path = preset_path(preset)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ValueError(f"preset file {path} is not valid YAML: {' '.join(str(error).split())}") from error
    data = {} if data is None else data
    if not isinstance(data, dict):
        raise ValueError(f"preset file {path} must be a mapping with the sections {', '.join(PRESET_SECTIONS)} "
                         f"(see {PRESET_DIR / 'cpu.yaml'}); found {type(data).__name__}")
    _check_preset_keys(data, f"preset file {path}")
    return data


def _check_preset_keys(data: dict, where: str) -> None:
    for section in data:
        if section not in PRESET_SECTIONS:
            raise ValueError(f"{where}: unknown section {section!r}{did_you_mean(str(section), PRESET_SECTIONS)} "
                             f"(sections {', '.join(PRESET_SECTIONS)}; see {PRESET_DIR / 'cpu.yaml'})")
    _check_block_keys(data.get("env"), where, "env", lambda key: unknown_setting("env", key))
    algos = data.get("algos") or {}
    if not isinstance(algos, dict):
        raise ValueError(f"{where}: algos must map algorithm names ({', '.join(ALGOS)}) to their settings")
    for algo, block in algos.items():
        if algo not in ALGOS:
            raise ValueError(f"{where}: unknown algorithm block {algo!r} under algos{did_you_mean(str(algo), ALGOS)} "
                             f"(the algorithms: {', '.join(ALGOS)})")
        _check_block_keys(block, where, f"algos.{algo}",
                          lambda key, algo=algo: unknown_setting("algo", key, algo, f"algos.{algo}."))
    _check_block_keys(data.get("run"), where, "run", lambda key: unknown_setting("run", key))


def _check_block_keys(block, where: str, path: str, problem) -> None:
    """A ValueError for the first key of ``block`` that ``problem(key)`` finds fault with."""
    if block is None:
        return
    if not isinstance(block, dict):
        raise ValueError(f"{where}: {path} must be a mapping of settings, not {type(block).__name__}")
    for key in block:
        text = problem(str(key))
        if text:
            raise ValueError(f"{where}: {text}")


# ``--set`` sections and the model of each; other keys are TrainConfig's own (task, episodes, max_cpu_hours, ...)
OVERRIDE_SECTIONS = {"env": "env", "algo": "algo_params", "run": "run"}


def check_override_key(assignment: str, algo: str) -> None:
    """A ValueError, naming the nearest valid key, unless ``assignment`` is ``section.key=value``
    with a key of env, run or ``algo``'s model, or ``key=value`` with a top-level key (``max_cpu_hours=2``)."""
    if "=" not in assignment:
        raise ValueError(f"override {assignment!r} must look like section.key=value")
    dotted = assignment.split("=", 1)[0].strip()
    parts = dotted.split(".")
    top_level = [key for key in TrainConfig.model_fields if key not in OVERRIDE_SECTIONS.values()]
    if len(parts) == 1:
        if parts[0] not in top_level:
            valid = top_level + [f"{section}.KEY" for section in OVERRIDE_SECTIONS]
            raise ValueError(f"--set {assignment}: unknown key {dotted}{did_you_mean(dotted, top_level)} "
                             f"(valid: {', '.join(valid)})")
        return
    section, key = parts[0], ".".join(parts[1:])
    if section not in OVERRIDE_SECTIONS:
        raise ValueError(f"--set {assignment}: unknown section {section}{did_you_mean(section, OVERRIDE_SECTIONS)} "
                         f"(the sections: {', '.join(OVERRIDE_SECTIONS)})")
    problem = unknown_setting(section, key, algo)
    if problem:
        raise ValueError(f"--set {assignment}: {problem}")


def _apply_override(tree: dict, assignment: str) -> None:
    """``section.key=value`` with a YAML-parsed value (``env.n_envs=4``, ``algo.net_arch=[64,64]``)."""
    check_override_key(assignment, tree["algo"])
    dotted, raw = assignment.split("=", 1)
    *parents, key = dotted.strip().split(".")
    node = tree
    for part in parents:
        node = node.setdefault(OVERRIDE_SECTIONS[part], {})
    node[key] = yaml.safe_load(raw)


def resolve_config(task: str, algo: str, seed: int = 0, preset: str = "cpu", episodes: int = 1000,
                   device: str = "auto", overrides: list[str] = (), max_hours: float | None = None) -> TrainConfig:
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; valid algorithms: {', '.join(ALGOS)}")
    data = load_preset(preset)
    tree = {
        "task": task, "algo": algo, "seed": seed, "preset": recorded_preset(preset), "episodes": episodes,
        "device": device,
        "max_hours": max_hours, "env": data.get("env", {}), "algo_params": data.get("algos", {}).get(algo, {}),
        "run": data.get("run", {}),
    }
    for assignment in overrides:
        _apply_override(tree, assignment)
    return _validated(tree)


def _validated(tree: dict) -> TrainConfig:
    try:
        return TrainConfig.model_validate(tree)
    except ValidationError as error:
        raise ValueError(f"invalid configuration: {validation_line(error)}") from None


def validation_line(error: ValidationError) -> str:
    """pydantic's errors as one line, each with its key as ``--set`` spells it (``algo.batch_size``)."""
    return "; ".join(_error_text(detail) for detail in error.errors())


def _error_text(detail: dict) -> str:
    location = ".".join("algo" if part == "algo_params" else str(part) for part in detail["loc"])
    message = detail["msg"].removeprefix("Value error, ")
    if detail["type"] == "extra_forbidden":
        message = "unknown key"
    text = f"{location}: {message}" if location and f"{location}." not in message else message
    return " ".join(text.split())  # pydantic's messages may span lines


def with_overrides(config: TrainConfig, overrides: list[str]) -> TrainConfig:
    """``config`` with any ``section.key=value`` overrides (for a new model; a resumed run uses
    ``override_config``, which refuses what its checkpoint cannot follow)."""
    tree = config.model_dump()
    for assignment in overrides:
        _apply_override(tree, assignment)
    return _validated(tree)


def resumable_settings(algo: str) -> list[str]:
    """What ``--set`` may change on a resumed ``algo`` run: every ``run.`` key, the budget and the
    algorithm's resumable keys (``resumable``)."""
    return (["run.*"] + resumable_keys(TrainConfig)
            + [f"algo.{key}" for key in resumable_keys(CONFIG_OF_ALGO[algo])])


def override_config(config: TrainConfig, overrides: list[str]) -> tuple[TrainConfig, dict[str, object]]:
    """``--set`` on a resumed run: the new config and the changed algorithm parameters; only
    ``resumable_settings`` may change."""
    tree = config.model_dump()
    allowed = resumable_settings(config.algo)
    for assignment in overrides:
        check_override_key(assignment, config.algo)
        dotted = assignment.split("=", 1)[0].strip()
        if not (dotted.startswith("run.") or dotted in allowed):
            raise ValueError(f"cannot change {dotted!r} when resuming; resumable keys: {', '.join(allowed)}")
        _apply_override(tree, assignment)
    updated = _validated(tree)
    before, after = config.algo_params.model_dump(), updated.algo_params.model_dump()
    return updated, {key: after[key] for key in after if after[key] != before[key]}


def save_config(config: TrainConfig, path: Path) -> None:
    path.write_text(yaml.safe_dump(config.model_dump(), sort_keys=False))


def read_config(path: Path) -> TrainConfig:
    try:
        return _validated(with_algorithms_keys_only(yaml.safe_load(Path(path).read_text())))
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None


def with_algorithms_keys_only(tree: dict) -> dict:
    """A ``config.yaml``'s tree with ``algo_params`` reduced to its algorithm's keys. Files written
    before one model per algorithm list every algorithm's keys there, the unset ones null: nulls
    (which mean the default) and other algorithms' keys at their defaults are dropped; another
    algorithm's key set to anything else is a ValueError."""
    params, model = tree.get("algo_params"), CONFIG_OF_ALGO.get(tree.get("algo"))
    if model is None or not isinstance(params, dict):
        return tree  # validation says what is wrong
    kept = {}
    for key, value in params.items():
        if value is None or (key not in model.model_fields and _is_a_default(key, value)):
            continue
        if key not in model.model_fields and algos_with_key(key):
            raise ValueError(f"invalid configuration: {unknown_algo_key(key, tree['algo'])} (set to {value!r})")
        kept[key] = value
    return dict(tree, algo_params=kept)


def _is_a_default(key: str, value) -> bool:
    """Whether ``value`` is ``key``'s default in the models that have it."""
    return any(value == CONFIG_OF_ALGO[algo].model_fields[key].get_default(call_default_factory=True)
               for algo in algos_with_key(key))
