from pathlib import Path

import pytest
import yaml

from relmogen.experiments.config import (ALGOS, available_presets, override_config, read_config, resolve_config,
                                         resumable_settings, save_config)


def test_presets_exist_and_validate():
    assert {"paper", "cpu", "tiny"} <= set(available_presets())
    for preset in available_presets():
        for algo in ("relmogen-r", "relmogen-d", "sac", "oac"):
            resolve_config("PushDoorNav", algo, preset=preset)


def test_paper_preset_has_the_paper_hyperparameters():
    config = resolve_config("PushDoorNav", "relmogen-r", preset="paper")
    assert config.env.n_envs == 16 and config.env.image_size == 128
    params = config.algo_params
    assert (params.batch_size, params.buffer_size, params.learning_starts) == (256, 10_000, 200)
    assert (params.learning_rate, params.tau, params.gamma) == (3e-4, 0.005, 0.99)
    assert config.control == "subgoal-r"


def test_every_value_can_be_overridden():
    config = resolve_config("PointNav", "sac", preset="cpu",
                            overrides=["algo.batch_size=32", "env.n_envs=4", "algo.net_arch=[64, 64]", "run.eval_episodes=3"])
    assert config.algo_params.batch_size == 32 and config.env.n_envs == 4
    assert config.algo_params.net_arch == [64, 64] and config.run.eval_episodes == 3


@pytest.mark.parametrize("kwargs,message", [
    (dict(algo="ppo"), "valid algorithms"),
    (dict(preset="huge"), "valid presets"),
    (dict(overrides=["algo.batch_size=-1"]), "batch_size"),
    (dict(overrides=["algo.not_a_key=1"]), "not_a_key"),
    (dict(overrides=["nonsense"]), "section.key=value"),
    (dict(algo="relmogen-r", overrides=["env.arm_rrt=[0,4]"]), "arm_rrt"),
    (dict(algo="relmogen-d", overrides=["algo.qmap_skip=true", "algo.qmap_unet=true"]), "choose one"),
    (dict(algo="relmogen-d", overrides=["env.reach_mask=cube"]), "reach_mask"),
])
def test_bad_configuration_is_refused_with_a_reason(kwargs, message):
    args = dict(task="PointNav", algo="sac") | kwargs
    with pytest.raises(ValueError, match=message):
        resolve_config(**args)


@pytest.mark.parametrize("assignment,message", [
    ("algo.batchsize=32", "--set algo.batchsize=32: unknown key algo.batchsize; did you mean algo.batch_size?"),
    ("env.imagesize=64", "--set env.imagesize=64: unknown key env.imagesize; did you mean env.image_size?"),
    ("run.evl_every=1", "--set run.evl_every=1: unknown key run.evl_every; did you mean run.eval_every_episodes?"),
    ("max_cpu_hour=1", "--set max_cpu_hour=1: unknown key max_cpu_hour; did you mean max_cpu_hours? (valid: task,"),
    ("evn.image_size=64", "--set evn.image_size=64: unknown section evn; did you mean env? (the sections: env,"),
    ("algo.zzzz=1", "--set algo.zzzz=1: unknown key algo.zzzz"),
])
def test_an_unknown_set_key_is_one_line_with_the_nearest_valid_key(assignment, message):
    for refused in (lambda: resolve_config("PointNav", "relmogen-r", preset="tiny", overrides=[assignment]),
                    lambda: override_config(resolve_config("PointNav", "relmogen-r", preset="tiny"), [assignment])):
        with pytest.raises(ValueError) as error:
            refused()
        assert str(error.value).startswith(message) and "\n" not in str(error.value)


def test_invalid_values_are_one_line_naming_each_key_as_set_spells_it():
    with pytest.raises(ValueError) as error:
        resolve_config("PointNav", "relmogen-r", preset="tiny", overrides=["env.image_size=8", "algo.gamma=2"])
    assert str(error.value) == ("invalid configuration: env.image_size: Input should be greater than or equal to 16; "
                                "algo.gamma: Input should be less than or equal to 1")
    with pytest.raises(ValueError, match=r"^invalid configuration: algo.qmap_skip and algo.qmap_unet are two Q-map "
                                         r"heads: choose one$"):
        resolve_config("PointNav", "relmogen-d", preset="tiny", overrides=["algo.qmap_skip=true", "algo.qmap_unet=true"])


@pytest.mark.parametrize("content,message", [
    ("algos:\n  relmogen_r:\n    batch_size: 32\n",
     "unknown algorithm block 'relmogen_r' under algos; did you mean relmogen-r? (the algorithms: relmogen-r,"),
    ("algos:\n  relmogen-r:\n    batchsize: 32\n",
     "unknown key algos.relmogen-r.batchsize; did you mean algos.relmogen-r.batch_size?"),
    ("algos:\n  sac: {batch_size: 32}\n  relmogen-r:\n    batchsize: 32\n", "algos.relmogen-r.batchsize"),
    ("env:\n  imagesize: 64\n", "unknown key env.imagesize; did you mean env.image_size?"),
    ("run:\n  evl_every: 1\n", "unknown key run.evl_every; did you mean run.eval_every_episodes?"),
    ("algo:\n  sac: {}\n", "unknown section 'algo'; did you mean algos? (sections env, algos, run;"),
    ("env: 64\n", "env must be a mapping of settings, not int"),
])
def test_a_preset_with_an_unknown_block_or_key_is_one_line_with_the_nearest_valid_one(tmp_path, content, message):
    """Whichever algorithm is trained: a misspelt block of another one is refused too, not ignored."""
    (tmp_path / "typo.yaml").write_text(content)
    with pytest.raises(ValueError) as error:
        resolve_config("PointNav", "sac", preset=str(tmp_path / "typo.yaml"))
    assert str(error.value).startswith(f"preset file {tmp_path / 'typo.yaml'}: ")
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_resumed_run_may_change_its_learning_schedule_and_reports_what_changed():
    config = resolve_config("PointNav", "relmogen-d", preset="cpu")
    updated, changed = override_config(config, ["algo.exploration_final_eps=0.2", "algo.buffer_size=50000",
                                                "algo.gamma=0.99", "run.eval_episodes=3"])
    assert changed == {"exploration_final_eps": 0.2, "buffer_size": 50000}  # gamma is unchanged
    assert updated.run.eval_episodes == 3 and updated.env == config.env
    assert override_config(config, ["algo.conservative_weight=0.5"])[1] == {"conservative_weight": 0.5}
    with_demos = resolve_config("ButtonDoorNav", "relmogen-d", preset="cpu", overrides=["algo.demo_episodes=5"])
    assert override_config(with_demos, ["algo.demo_margin_weight=2"])[1] == {"demo_margin_weight": 2.0}
    assert override_config(config, ["algo.n_step_returns=5"])[1] == {"n_step_returns": 5}
    longer, changed = override_config(config, ["max_cpu_hours=0.9", "episodes=5000"])
    assert (longer.max_cpu_hours, longer.episodes, changed) == (0.9, 5000, {})


def test_n_step_returns_are_refused_for_the_sac_family():
    with pytest.raises(ValueError, match="n_step_returns: relmogen-d only"):
        resolve_config("PointNav", "sac", preset="tiny", overrides=["algo.n_step_returns=3"])


@pytest.mark.parametrize(("algo", "overrides", "message"), [
    ("relmogen-r", ["algo.demo_episodes=5", "algo.demo_keep=true"], "demo_keep: relmogen-d only"),
    ("relmogen-d", ["algo.demo_margin_weight=1"], "set algo.demo_episodes too"),
    ("relmogen-d", ["algo.demo_keep=true", "algo.demo_margin_weight=1"], "demo_keep and demo_margin_weight"),
])
def test_demonstration_settings_are_refused_where_they_would_do_nothing(algo, overrides, message):
    with pytest.raises(ValueError, match=message):
        resolve_config("ButtonDoorNav", algo, preset="tiny", overrides=overrides)


@pytest.mark.parametrize(("task", "algo", "overrides", "message"), [
    ("ButtonDoorNav", "relmogen-r", ["algo.oracle_labels=true"], "oracle_labels: relmogen-d only"),
    ("ButtonDoorNav", "relmogen-d", ["algo.oracle_labels=true"], "set algo.demo_margin_weight > 0"),
    ("NoSuchTask", "relmogen-d", ["algo.oracle_labels=true", "algo.demo_margin_weight=1"], "no oracle for task"),
])
def test_oracle_labels_are_refused_where_they_would_do_nothing(task, algo, overrides, message):
    with pytest.raises(ValueError, match=message):
        resolve_config(task, algo, preset="tiny", overrides=overrides)


def test_oracle_labels_alone_may_carry_the_margin_term():
    config = resolve_config("ButtonDoorNav", "relmogen-d", preset="tiny",
                            overrides=["algo.oracle_labels=true", "algo.demo_margin_weight=1"])
    assert config.algo_params.oracle_labels and config.algo_params.demo_episodes == 0


@pytest.mark.parametrize("assignment", ["env.image_size=128", "algo.qmap_widths=[8, 8, 8, 8]", "task=PushDoorNav",
                                        "algo.mask_arm=false", "algo.demo_keep=true"])
def test_a_resumed_run_refuses_changes_its_checkpoint_cannot_follow(assignment):
    config = resolve_config("PointNav", "relmogen-d", preset="cpu")
    with pytest.raises(ValueError, match="when resuming"):
        override_config(config, [assignment])


@pytest.mark.parametrize("assignment", ["algo.exploration_final_eps=0.2", "algo.conservative_weight=1"])
def test_a_resumed_run_refuses_a_setting_its_algorithm_does_not_have(assignment):
    config = resolve_config("PointNav", "relmogen-r", preset="cpu")
    with pytest.raises(ValueError, match="relmogen-d only"):
        override_config(config, [assignment])


def test_a_preset_may_be_a_yaml_file_and_the_config_records_its_absolute_path(tmp_path, monkeypatch):
    (tmp_path / "mine.yaml").write_text("env:\n  image_size: 32\nrun:\n  eval_episodes: 2\n")
    monkeypatch.chdir(tmp_path)
    config = resolve_config("PointNav", "sac", preset="mine.yaml")
    assert config.preset == str(tmp_path / "mine.yaml") and config.env.image_size == 32
    assert config.run.eval_episodes == 2 and config.algo_params.batch_size == 256  # the schema's defaults
    assert resolve_config("PointNav", "sac", preset="tiny").preset == "tiny"


@pytest.mark.parametrize("content,message", [
    ("env: [1, 2\n", "not valid YAML"),
    ("- env\n", "must be a mapping"),
    ("environment:\n  image_size: 32\n", "sections env, algos, run"),
    ("env:\n  image_sise: 32\n", "image_sise"),
])
def test_a_bad_preset_file_is_refused_with_a_reason(tmp_path, content, message):
    (tmp_path / "bad.yaml").write_text(content)
    with pytest.raises(ValueError, match=message):
        resolve_config("PointNav", "sac", preset=str(tmp_path / "bad.yaml"))
    with pytest.raises(ValueError, match="does not exist"):
        resolve_config("PointNav", "sac", preset=str(tmp_path / "missing.yaml"))


@pytest.mark.parametrize("algo", ["relmogen-d", "hrl4in"])
def test_state_observations_are_refused_for_the_algorithms_that_need_images(algo):
    with pytest.raises(ValueError, match=f"env.obs_mode=state: {algo} needs images"):
        resolve_config("PointNav", algo, preset="tiny", overrides=["env.obs_mode=state"])


def test_state_observations_reach_the_environment_of_the_vector_policies():
    from relmogen.experiments.environments import env_kwargs

    for algo in ("relmogen-r", "sac", "oac"):
        config = resolve_config("PointNav", algo, preset="tiny", overrides=["env.obs_mode=state"])
        assert env_kwargs(config, arm_collision=True)["obs_mode"] == "state"
    assert env_kwargs(resolve_config("PointNav", "sac", preset="tiny"), arm_collision=True)["obs_mode"] == "rgbd"


@pytest.mark.parametrize(("algo", "assignment", "message"), [
    ("relmogen-r", "algo.qmap_widths=[8, 8]", "--set algo.qmap_widths=[8, 8]: algo.qmap_widths: relmogen-d only, "
                                              "not relmogen-r"),
    ("sac", "algo.beta_ub=1", "--set algo.beta_ub=1: algo.beta_ub: oac only, not sac"),
    ("relmogen-d", "algo.net_arch=[64]", "--set algo.net_arch=[64]: algo.net_arch: relmogen-r, sac, oac, hrl4in only, "
                                         "not relmogen-d"),
    ("relmogen-d", "algo.qmap_widht=[8]", "--set algo.qmap_widht=[8]: unknown key algo.qmap_widht; did you mean "
                                          "algo.qmap_widths?"),
])
def test_a_key_of_another_algorithm_is_one_line_naming_the_algorithms_that_have_it(algo, assignment, message):
    with pytest.raises(ValueError) as error:
        resolve_config("PointNav", algo, preset="tiny", overrides=[assignment])
    assert str(error.value) == message


def test_each_algorithm_has_its_own_keys_and_a_preset_block_of_another_algorithms_key_is_refused(tmp_path):
    keys = {algo: set(resolve_config("PointNav", algo, preset="tiny").algo_params.model_dump()) for algo in ALGOS}
    common = set.intersection(*keys.values())
    assert {"learning_rate", "buffer_size", "batch_size", "gamma", "tau"} <= common
    assert keys["relmogen-r"] == keys["sac"] and keys["oac"] - keys["sac"] == {"beta_ub", "delta"}
    assert "qmap_widths" in keys["relmogen-d"] - keys["relmogen-r"] and "hrl4in_k" in keys["hrl4in"] - keys["sac"]
    (tmp_path / "mixed.yaml").write_text("algos:\n  relmogen-r:\n    exploration_steps: 100\n")
    with pytest.raises(ValueError, match="algos.relmogen-r.exploration_steps: relmogen-d only, not relmogen-r$"):
        resolve_config("PointNav", "relmogen-r", preset=str(tmp_path / "mixed.yaml"))


def test_resumable_keys_come_from_the_models():
    assert "algo.exploration_final_eps" in resumable_settings("relmogen-d")
    assert "algo.exploration_final_eps" not in resumable_settings("relmogen-r")
    assert not {"algo.qmap_widths", "algo.mask_arm", "algo.demo_keep", "algo.net_arch"} & set(
        resumable_settings("relmogen-d") + resumable_settings("relmogen-r"))
    assert {"episodes", "max_hours", "max_cpu_hours", "algo.learning_rate"} <= set(resumable_settings("hrl4in"))


OLD_FLAT_FORM = Path(__file__).resolve().parents[2] / "results/table1/PointNav__relmogen-r"


@pytest.mark.parametrize("algo", ALGOS)
def test_a_saved_config_reads_back_the_same(tmp_path, algo):
    config = resolve_config("PointNav", algo, preset="cpu")
    save_config(config, tmp_path / "config.yaml")
    assert read_config(tmp_path / "config.yaml") == config


def test_a_config_in_the_old_flat_form_loads_and_a_set_key_of_another_algorithm_is_refused(tmp_path):
    """Before one model per algorithm, config.yaml listed every algorithm's keys, the unset ones null."""
    old = next(OLD_FLAT_FORM.glob("*/config.yaml"))
    tree = yaml.safe_load(old.read_text())
    assert tree["algo"] == "relmogen-r" and tree["algo_params"]["qmap_widths"] is None
    assert tree["algo_params"]["hrl4in_k"] == 30 and tree["algo_params"]["demo_keep"] is False
    config = read_config(old)
    assert "qmap_widths" not in config.algo_params.model_dump()
    assert config.algo_params.batch_size == tree["algo_params"]["batch_size"]
    tree["algo_params"]["hrl4in_k"] = 5
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(tree))
    with pytest.raises(ValueError, match=r"algo.hrl4in_k: hrl4in only, not relmogen-r \(set to 5\)$"):
        read_config(tmp_path / "config.yaml")
