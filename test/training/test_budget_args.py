"""The training commands refuse a budget that is not positive (it crashed or never ended before)."""

import pytest

from latent_planner_ros.training import train_collision, train_vae


@pytest.mark.parametrize("module", [train_vae, train_collision])
@pytest.mark.parametrize("budget", [["--iterations", "0"], ["--iterations", "-3"], ["--minutes", "0"]])
def test_a_budget_that_is_not_positive_is_refused(module, budget, capsys):
    with pytest.raises(SystemExit) as e:
        module.parse_args(budget)
    assert e.value.code == 2
    assert "must be positive" in capsys.readouterr().err


@pytest.mark.parametrize("module", [train_vae, train_collision])
def test_the_default_budget_is_an_hour(module):
    args, _ = module.parse_args([])
    assert (args.minutes, args.iterations) == (60.0, None)
    args, _ = module.parse_args(["--iterations", "5"])
    assert (args.minutes, args.iterations) == (None, 5)
