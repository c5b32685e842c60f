"""examples/ppo_trail_diver.py without torch: its command line, the schedule of
evaluations, checkpoints and the wall-clock budget, the output folder (settings,
checkpoints, resuming, the learning curve), the action scaling and the figure. The
training itself needs torch and stable-baselines3, which the suite never installs
(tests/integration/test_envs_ppo_example.py runs it where they are)."""

import json
import subprocess
import sys

import numpy as np
import pytest
from gymnasium import spaces

from tests.support.examples import EXAMPLES, load_example

ppo = load_example("ppo_trail_diver")


def test_importing_the_example_loads_neither_torch_nor_stable_baselines3():
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import ppo_trail_diver; "
            "print(sorted({'torch', 'stable_baselines3'} & set(sys.modules)))")
    done = subprocess.run([sys.executable, "-c", code, str(EXAMPLES)], capture_output=True,
                          text=True, check=True)
    assert done.stdout.strip() == "[]"


def test_command_line_defaults():
    args = ppo.parse_args([])
    assert args.minutes is None and args.threads == 1 and args.vector == "native"
    assert args.env == ppo.STATE_ENV and args.eval_seeds == ppo.EVAL_SEEDS
    args = ppo.parse_args(["--minutes", "2.5", "--eval-seeds", "3, 4,5", "--envs", "8"])
    assert args.minutes == 2.5 and args.eval_seeds == (3, 4, 5) and args.envs == 8


@pytest.mark.parametrize(("argv", "message"), [
    (["--minutes", "0"], "--minutes: must be a number > 0, got 0"),
    (["--steps", "-5"], "--steps: must be an integer >= 1, got -5"),
    (["--eval-seeds", "1,x"], "--eval-seeds: must be comma-separated integers"),
    (["--eval-seeds", "-1"], "--eval-seeds: must be non-negative integers"),
    (["--threads", "-1"], "--threads: must be >= 0, got -1"),
    (["--pilings", "-2"], "--pilings: must be >= 0, got -2"),
    (["--env", ppo.SONAR_ENV], "use --vector process with the sonar env"),
])
def test_bad_arguments_are_one_line_errors(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        ppo.parse_args(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err


class Clock:
    """A clock the test moves by hand (seconds)."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_evaluations_and_checkpoints_fall_due_at_each_multiple_once():
    schedule = ppo.Schedule(eval_every=50_000, checkpoint_every=100_000, max_steps=10**9,
                            budget_s=None, clock=Clock())
    assert not schedule.evaluation_due(16) and not schedule.checkpoint_due(16)
    # the vector env advances 16 steps at a time: the first count past a multiple is due
    due = [s for s in range(16, 210_000, 16) if schedule.evaluation_due(s)]
    assert due[0] == 50_000
    schedule.last_eval = 50_000
    assert not schedule.evaluation_due(99_984) and schedule.evaluation_due(100_000)
    assert not schedule.checkpoint_due(99_984) and schedule.checkpoint_due(100_000)
    schedule.last_eval = 50_000  # a resumed run from 50 000 steps
    assert schedule.evaluation_due(100_016) and not schedule.evaluation_due(50_016)


def test_the_budget_keeps_back_the_last_evaluation_and_the_steps_stop_the_run():
    clock = Clock()
    schedule = ppo.Schedule(eval_every=10, checkpoint_every=10, max_steps=1_000,
                            budget_s=600.0, clock=clock)
    clock.now += 590.0
    assert schedule.elapsed_s() == 590.0 and not schedule.should_stop(500)
    schedule.reserve_s = 12.0  # the last evaluation took 12 s: no time left for one more
    assert schedule.out_of_time() and schedule.should_stop(500)
    schedule.reserve_s = 0.0
    assert schedule.should_stop(1_000)
    clock.now += 10.0
    assert schedule.out_of_time()
    endless = ppo.Schedule(10, 10, 1_000, budget_s=None, clock=clock)
    clock.now += 1e9
    assert not endless.out_of_time() and endless.should_stop(1_000)


def row(steps, wall_s, eval_return):
    return {"env_steps": steps, "wall_s": wall_s, "eval_return": eval_return,
            "eval_return_std": 10.0, "eval_position_error_m": 1.5, "helm_return": 260.0,
            "helm_position_error_m": 1.76, "train_episode_return": float("nan"),
            "steps_per_s": 2400.0}


def test_curve_rows_round_trip_and_truncate_at_a_checkpoint(tmp_path):
    path = tmp_path / "curve.csv"
    assert ppo.read_curve(path) == []
    for steps, wall, ret in ((0, 14.0, -8.7), (50_000, 40.5, 60.25), (100_000, 70.0, 130.0)):
        ppo.append_curve(path, row(steps, wall, ret))
    rows = ppo.read_curve(path)
    assert [r["env_steps"] for r in rows] == [0, 50_000, 100_000]
    assert rows[1]["eval_return"] == 60.25 and np.isnan(rows[0]["train_episode_return"])
    assert path.read_text().splitlines()[0] == ",".join(ppo.CURVE_FIELDS)
    ppo.truncate_curve(path, 60_000)
    assert [r["env_steps"] for r in ppo.read_curve(path)] == [0, 50_000]


def checkpoint(out, steps, statistics=True):
    path = ppo.checkpoint_path(out, steps)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"model")
    if statistics:
        ppo.statistics_path(path).write_bytes(b"statistics")
    return path


def test_a_new_run_writes_its_settings_and_refuses_a_folder_that_holds_one(tmp_path):
    out = tmp_path / "run"
    args = ppo.parse_args(["--out", str(out), "--pilings", "2", "--eval-seeds", "7,8"])
    settings, start = ppo.prepare_run(args)
    assert start is None
    assert json.loads((out / "run.json").read_text()) == settings
    assert settings["pilings"] == 2 and settings["eval_seeds"] == [7, 8]
    assert ppo.env_kwargs(settings) == {"randomization": {"clutter": 2}}
    with pytest.raises(ppo.RunError, match="already holds a run: add --resume"):
        ppo.prepare_run(args)


def test_resume_takes_the_last_complete_checkpoint_and_the_saved_settings(tmp_path):
    out = tmp_path / "run"
    ppo.prepare_run(ppo.parse_args(["--out", str(out), "--envs", "8"]))
    resume = ppo.parse_args(["--out", str(out), "--resume", "--envs", "32"])
    with pytest.raises(ppo.RunError, match=r"nothing to resume in .*no checkpoint"):
        ppo.prepare_run(resume)
    checkpoint(out, 100_000)
    second = checkpoint(out, 200_000)
    checkpoint(out, 300_000, statistics=False)  # killed while saving: not complete
    assert [s for s, _ in ppo.checkpoints(out)] == [100_000, 200_000]
    (out / "checkpoints" / "ppo_latest.zip").write_bytes(b"not one of ours")
    for steps in (0, 100_000, 200_000, 250_000):
        ppo.append_curve(out / "curve.csv", row(steps, steps / 1000, 1.0))
    settings, start = ppo.prepare_run(resume)
    assert start == (second, 200_000)
    assert settings["envs"] == 8  # the run's own, not the command line's
    assert [r["env_steps"] for r in ppo.read_curve(out / "curve.csv")] == [0, 100_000,
                                                                           200_000]


def test_resume_names_a_broken_settings_file(tmp_path):
    out = tmp_path / "run"
    checkpoint(out, 100)
    (out / "run.json").write_text('{"env": "x",\n "vector": }\n')
    with pytest.raises(ppo.RunError, match=r"run.json:2: not JSON"):
        ppo.prepare_run(ppo.parse_args(["--out", str(out), "--resume"]))
    (out / "run.json").write_text('{"env": "x"}\n')
    with pytest.raises(ppo.RunError, match=r"run\.json: missing vector, envs, pilings"):
        ppo.prepare_run(ppo.parse_args(["--out", str(out), "--resume"]))


def test_actions_in_the_unit_box_map_linearly_onto_the_env_box():
    box = spaces.Box(np.array([-np.pi, 0.0, -2.0], np.float32),
                     np.array([np.pi, 1.0, 2.0], np.float32))
    scale = ppo.ActionScale(box)
    actions = scale(np.array([[-1, -1, -1], [1, 1, 1], [0, 0, 0.5], [3, -7, 0]]))
    assert actions.dtype == np.float32
    np.testing.assert_allclose(actions, [[-np.pi, 0, -2], [np.pi, 1, 2], [0, 0.5, 1],
                                         [np.pi, 0, 0]], atol=1e-6)


def test_progress_line_reports_the_evaluation_beside_the_helm():
    line = ppo.progress_line(row(1_234_567, 754.0, 364.0), best=380.0)
    assert "\n" not in line
    for part in ("1,234,567 steps", " 12:34 ", "2400 steps/s", "return  364.0 ±  10.0",
                 "1.50 m from the trail point", "helm 260.0, 1.76 m (PPO at 140 % of it)",
                 "best 380.0", "training episodes -"):
        assert part in line, part
    assert "PPO at" not in ppo.progress_line(row(0, 14.0, -8.7), best=-8.7)


def test_the_figure_has_a_panel_per_axis_and_the_stated_size(tmp_path):
    import matplotlib.image

    rows = [row(s, 20.0 + s / 2000, r) for s, r in ((0, -8.0), (50_000, 90.0),
                                                   (100_000, 300.0))]
    path = tmp_path / "img" / "curve.png"
    ppo.plot_curve(rows, path, "PPO test")
    assert matplotlib.image.imread(path).shape[:2] == (440, 1100)  # 10 x 4 in at 110 dpi


def test_pruning_keeps_the_latest_checkpoints(tmp_path):
    for steps in (100, 200, 300, 400):
        checkpoint(tmp_path, steps)
    ppo.prune_checkpoints(tmp_path, keep=2)
    assert [s for s, _ in ppo.checkpoints(tmp_path)] == [300, 400]
    assert sorted(p.name for p in (tmp_path / "checkpoints").iterdir()) == [
        "ppo_0000000300.zip", "ppo_0000000300_vecnormalize.pkl", "ppo_0000000400.zip",
        "ppo_0000000400_vecnormalize.pkl"]
