"""The campaign loader: the packaged campaign, another one through ``--campaign``, and one-line errors."""

from __future__ import annotations

import copy

import pytest
import yaml

from baselines.campaign import DEFAULT_CAMPAIGN, CampaignError, Study, default_campaign, load_campaign
from baselines.programme import main, step_names


def packaged() -> dict:
    return yaml.safe_load(DEFAULT_CAMPAIGN.read_text())


def write(tmp_path, data) -> str:
    path = tmp_path / "campaign.yaml"
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    return str(path)


def test_the_packaged_campaign_loads_typed():
    campaign = load_campaign()
    assert campaign == default_campaign()
    assert campaign.studies[0] == Study("ppo", "paper", 30)
    assert campaign.runs[2].timesteps is None and campaign.runs[0].seeds == (0, 1, 2, 3, 4)
    assert campaign.regime_flags["random"][-1] == "0.5" and campaign.confirmed == ("ppo",)
    with pytest.raises(AttributeError):
        campaign.confirmed = ()  # frozen


def test_another_campaign_drives_the_programme(tmp_path, capsys):
    data = packaged()
    data["studies"] = [{"algo": "td3", "regime": "paper", "trials": 2}]
    data["runs"] = [{"algo": "td3", "regime": "paper", "seeds": [7], "timesteps": 1000}]
    data["experiments"], data["confirmed"] = [], []
    path = write(tmp_path, data)
    assert step_names(load_campaign(path)) == ["tune/td3-paper", "train/td3-paper-s7"]
    assert main(["--root", str(tmp_path / "rl"), "--campaign", path, "--dry-run"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"[plan] tune/td3-paper (0/2 trials): uav-bench tune --algo td3 --regime paper --trials 2 "
        f"--out {tmp_path}/rl/tune/td3-paper",
        "[wait] train/td3-paper-s7: waits for tune/td3-paper",
    ]


def change(edit):
    data = packaged()
    edit(data)
    return data


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ("studies: [", "not valid YAML at line 1; expected a campaign YAML file"),
        ("- 1", "campaign: got [1]; expected a mapping with studies, runs"),
        (change(lambda d: d.pop("runs")), "campaign: runs is missing; expected the keys studies, runs"),
        (change(lambda d: d.update(run=[])), "campaign.run: got 'run'; expected one of studies, runs, experiments, off_policy_cpu_minutes, confirmed, eval_freq, checkpoint_freq, eval_episodes, regime_flags (did you mean 'runs'?)"),
        (change(lambda d: d["studies"][1].update(trials=0)), "studies[1].trials: got 0; expected an integer >= 1"),
        (change(lambda d: d["studies"][0].update(trials=True)), "studies[0].trials: got True; expected an integer"),
        (change(lambda d: d["studies"][0].update(algo="a2c")), "studies[0].algo: got 'a2c'; expected one of ppo, sac, td3 (did you mean 'sac'?)"),
        (change(lambda d: d["studies"][0].update(regime="papr")), "studies[0].regime: got 'papr'; expected one of paper, random (did you mean 'paper'?)"),
        (change(lambda d: d["studies"].append(d["studies"][0])), "studies[5]: got 'ppo-paper'; expected one study per"),
        (change(lambda d: d["studies"][0].pop("trials")), "studies[0]: trials is missing; expected the keys algo, regime, trials"),
        (change(lambda d: d["runs"][0].update(seeds=[0, 0])), "runs[0].seeds: got [0, 0]; expected a non-empty list of distinct"),
        (change(lambda d: d["runs"][1].update(seeds=[1, 2])), "runs[1].seeds: got [1, 2]; expected seeds including 0 (ppo is confirmed)"),
        (change(lambda d: d["runs"][0].update(seeds=[-1])), "runs[0].seeds[0]: got -1; expected an integer >= 0"),
        (change(lambda d: d["runs"][0].update(timesteps="2M")), "runs[0].timesteps: got '2M'; expected an integer >= 1"),
        (change(lambda d: d["runs"][4].update(regime="random")), "runs[4]: got 'td3-random'; expected the algorithm and regime of a study"),
        (change(lambda d: d["experiments"][0].update(timesteps=None)), "experiments[0].timesteps: got None; expected an integer"),
        (change(lambda d: d["experiments"][0].update(overrides="")), "experiments[0].overrides: got ''; expected a non-empty string"),
        (change(lambda d: d["experiments"][0].update(flags=["--timesteps", "5"])), "experiments[0].flags[0]: got '--timesteps'; expected one of --shaping, --action, --clearance, --features, --init-from, --critic-warmup"),
        (change(lambda d: d["experiments"][0].update(flags=["--action"])), "experiments[0].flags: got ['--action']; expected pairs of a flag and its value"),
        (change(lambda d: d.update(off_policy_cpu_minutes=0)), "off_policy_cpu_minutes: got 0; expected a number > 0"),
        (change(lambda d: d.update(confirmed=["ppo", "dqn"])), "confirmed[1]: got 'dqn'; expected one of ppo, sac, td3"),
        (change(lambda d: d["checkpoint_freq"].pop("td3")), "checkpoint_freq: got ['ppo', 'sac']; expected the algorithms of eval_freq"),
        (change(lambda d: d["eval_freq"].update(ppo=0)), "eval_freq.ppo: got 0; expected an integer >= 1"),
        (change(lambda d: d["eval_episodes"].pop("random")), "eval_episodes: got ['paper']; expected the regimes of regime_flags"),
        (change(lambda d: d["regime_flags"].update(random=["--difficulty", 0.5])), "regime_flags.random: got ['--difficulty', 0.5]; expected a list of strings"),
    ],
)  # fmt: skip
def test_a_bad_campaign_is_refused_in_one_line_naming_the_field(tmp_path, data, expected):
    path = write(tmp_path, copy.deepcopy(data))
    with pytest.raises(CampaignError) as error:
        load_campaign(path)
    message = str(error.value)
    assert message.startswith(f"{path}: ") and expected in message and "\n" not in message


def test_a_bad_campaign_flag_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--campaign", str(tmp_path / "missing.yaml"), "--dry-run"])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2
    assert (
        f"--campaign {tmp_path}/missing.yaml: cannot be read" in err
        and "expected a campaign YAML file" in err
    )
