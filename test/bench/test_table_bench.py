"""`bench table` end to end on 3 problems x 2 planners, and its refusals."""

import json

import pytest

from latent_planner_ros.bench.scenario_generator import GeneratorConfig, generate_set
from latent_planner_ros.bench.scenarios import save_scenarios
from latent_planner_ros.bench.table import main as bench_table
from latent_planner_ros.bench.table_planners import parse_planners

FIELDS = {
    "n",
    "success",
    "success_ci95",
    "time_median_s",
    "time_p95_s",
    "path_len_median",
    "path_len_std",
    "speedup_vs_rrtconnect",
    "joint_path_median_rad",
    "ee_path_median_m",
    "unsafe",
}


@pytest.mark.slow
def test_bench_table_writes_every_field(tmp_path):
    scenarios = save_scenarios(generate_set(GeneratorConfig(problems=3, seed=77), progress=False), tmp_path / "s.json")
    argv = ["--out", str(tmp_path / "out"), "--scenarios", str(scenarios), "--planners", "amp_ls,rrtconnect"]
    assert bench_table([*argv, "--backend", "geometric", "--workers", "1"]) == 0
    data = json.loads((tmp_path / "out" / "table.json").read_text())
    assert set(data["planners"]) == {"amp_ls", "rrtconnect"}
    for name, stats in data["planners"].items():
        assert FIELDS <= set(stats), (name, FIELDS - set(stats))
        assert stats["n"] == 3 and 0.0 <= stats["success_ci95"][0] <= stats["success"] <= stats["success_ci95"][1]
        assert stats["time_median_s"] > 0
    assert data["planners"]["rrtconnect"]["speedup_vs_rrtconnect"] == pytest.approx(1.0)
    assert len(data["rows"]) == 6 and {r["cloud_points"] for r in data["rows"]} != {0}
    assert data["_meta"]["command"].startswith("python -m latent_planner_ros bench table")
    md = (tmp_path / "out" / "table.md").read_text()
    assert "| `amp_ls` |" in md and "| `rrtconnect` |" in md
    for fig in ("success_time", "success", "times", "path_length"):
        assert (tmp_path / "out" / f"table_{fig}.png").exists(), fig
    # where the time goes: the parts of each planner's split add up to its total
    for name, stats in data["planners"].items():
        split = stats["time_split_ms"]
        parts = sum(v for k, v in split.items() if k not in ("total", "checked_states", "plans"))
        assert parts == pytest.approx(split["total"], rel=0.02), (name, split)
        assert split["plans"] >= 1
    assert data["planners"]["amp_ls"]["time_split_ms"]["checked_states"] > 0
    assert "Where the time goes" in md and "- `amp_ls`:" in md


def test_bench_table_refuses_a_bad_set_and_unknown_planners(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"name": "x", "table": True, "problems": [{"start": [0] * 7}]}))
    assert bench_table(["--out", str(tmp_path), "--scenarios", str(bad)]) == 2
    assert "bad.json: problems[0].start: joint 4" in capsys.readouterr().err
    with pytest.raises(ValueError, match="rrt_connect"):
        parse_planners("amp_ls,rrt_connect", "learned")
    assert "amp_ls_geometric" not in parse_planners(None, "geometric")


def test_the_report_breaks_success_down_per_family_and_inside_goals():
    from latent_planner_ros.bench.table_report import figures, markdown, summarise

    def row(i, family, inside, ok):
        reason = "" if ok else "no progress"
        return {"problem": i, "planner": "amp_ls", "family": family, "inside": inside, "success": ok,
                "claimed": ok, "reached": ok, "collision": None, "time_s": 0.01 * (i + 1), "reason": reason,
                "path_len_norm": 1.2, "joint_path_rad": 1.0, "ee_path_m": 0.5, "timings": {}}  # fmt: skip

    rows = [row(0, "bin", True, True), row(1, "bin", False, False), row(2, "cage", False, True)]
    fam = summarise(rows, ["amp_ls"])["amp_ls"]["families"]
    assert fam["bin"]["n"] == 2 and fam["bin"]["successes"] == 1 and fam["cage"]["success"] == 1.0
    assert fam["inside goals"]["n"] == 1 and fam["inside goals"]["successes"] == 1
    assert summarise([row(0, "unnamed", False, True)], ["amp_ls"])["amp_ls"]["families"] == {}
    results = {"planners": summarise(rows, ["amp_ls"]), "scenarios": {"name": "w", "problems": 3, "problems_run": 3,
               "table": True}, "backend": "learned", "tolerance": {"position_m": 0.01, "orientation_deg": 15.0},
               "budgets": {}}  # fmt: skip
    assert "| `amp_ls` | 0.50 (1/2)" in markdown(results) and "`inside goals`" in markdown(results)
    rows += [row(3, "bin", False, True) | {"planner": "rrtconnect"}]  # a row without every family
    results["planners"] = summarise(rows, ["amp_ls", "rrtconnect"])
    assert "families" in figures(results, rows)


def test_grasp_problems_are_their_own_group_with_unsafe_plans():
    from latent_planner_ros.bench.table_report import summarise

    def row(i, ok, collision=None):
        return {"problem": i, "planner": "amp_ls", "family": "bin", "inside": False, "grasp": True, "success": ok,
                "claimed": True, "reached": True, "collision": collision, "time_s": 0.1, "reason": "",
                "path_len_norm": 1.2, "joint_path_rad": 1.0, "ee_path_m": 0.5, "timings": {}}  # fmt: skip

    fam = summarise([row(0, True), row(1, False, "obstacle")], ["amp_ls"])["amp_ls"]["families"]
    assert fam["grasp goals"]["n"] == 2 and fam["grasp goals"]["successes"] == 1 and fam["grasp goals"]["unsafe"] == 1


def test_a_grasp_problem_runs_through_plan_grasp_for_every_planner(tmp_path):
    from latent_planner_ros.bench.grasp_problems import GraspSetConfig, generate_grasp_problem
    from latent_planner_ros.bench.table import TableRunner

    problem = generate_grasp_problem(0, GraspSetConfig(seed=9400, split="train"))
    rows = TableRunner(["amp_ls", "rrtconnect"], "geometric", table=True).run(0, problem)
    for r in rows:
        assert r["grasp"] and r["target_points"] > 0, r
        assert r["approach"], r
        assert not (r["claimed"] and r["collision"]), r


def test_amp_ls_settings_reach_every_amp_ls_row_and_bad_ones_are_refused(tmp_path, capsys):
    scenarios = save_scenarios(generate_set(GeneratorConfig(problems=2, seed=78), progress=False), tmp_path / "s.json")
    sets = ["max_steps=1", "finish=null", "escape=null", "guidance=null"]
    argv = ["--out", str(tmp_path / "out"), "--scenarios", str(scenarios), "--planners", "amp_ls,amp_ls_geometric"]
    assert bench_table([*argv, "--backend", "geometric", "--workers", "1", *[f"--amp-ls-set={s}" for s in sets]]) == 0
    data = json.loads((tmp_path / "out" / "table.json").read_text())
    assert data["amp_ls_overrides"] == {"max_steps": 1, "finish": None, "escape": None, "guidance": None}
    assert data["budgets"]["amp_ls"]["max_steps"] == 1 and data["budgets"]["amp_ls"]["rrt_escape_after_s"] is None
    assert {r["reason"] for r in data["rows"]} == {"step budget exhausted"}  # one step, nothing to finish with
    assert "`--amp-ls-set`" in (tmp_path / "out" / "table.md").read_text()
    for bad, why in (("nope=1", "unknown AMP-LS field 'nope'"), ("escape.after_s", "expected KEY=VALUE")):
        assert bench_table([*argv, f"--amp-ls-set={bad}"]) == 2
        assert why in capsys.readouterr().err
