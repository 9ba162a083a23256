from uav_penetration_env.suggest import close_matches, did_you_mean


def test_suggests_the_close_name_first():
    assert close_matches("ihspo", ["hpso", "ihpso", "lpso", "cmaes"])[0] == "ihpso"
    assert did_you_mean("radar", ["radars", "map", "goal"]) == "did you mean 'radars'? "


def test_no_hint_for_an_unrelated_name():
    assert did_you_mean("zzzz", ["radars", "map", "goal"]) == ""
    assert close_matches(42, ["radars"]) == []
