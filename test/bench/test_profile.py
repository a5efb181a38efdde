"""bench profile: the typical plans are profiled and their time is split into the plan's parts."""

import json
from types import SimpleNamespace

from latent_planner_ros.bench import profile


def _frame(cls, function, time, children=()):
    return SimpleNamespace(class_name=cls, function=function, time=time, children=list(children))


def test_part_times_are_the_direct_calls_of_the_plan_frames_summed_over_the_tree():
    search = _frame("AmpLs", "_search_and_finish", 7.0, [_frame("AmpLs", "iterate", 4.0), _frame("X", "finish", 3.0)])
    plan = _frame("AmpLs", "_plan_once", 10.0, [_frame("B", "set_scene", 3.0), search])
    again = _frame("AmpLs", "_plan_once", 2.0, [_frame("B", "set_scene", 2.0)])
    root = _frame(None, "<module>", 12.0, [_frame(None, "run", 12.0, [plan, again])])
    assert profile.part_times(root) == {"B.set_scene": 5.0, "AmpLs.iterate": 4.0, "X.finish": 3.0}


def test_profile_of_a_few_tabletop_plans_writes_the_report(tmp_path):
    assert profile.main(["--out", str(tmp_path), "--scenes", "5", "--repeats", "1"]) == 0
    results = json.loads((tmp_path / "profile.json").read_text())
    parts = results["parts_ms_per_plan"]
    assert results["plans_timed"] == 5 and 1 <= len(results["typical_problems"]) <= 5
    assert "AmpLs.iterate" in parts or "ExactFinish.direct_first" in parts  # a plan optimises or goes straight
    assert 0 < sum(parts.values()) <= results["profiled_ms_per_plan"] * 1.01
    md = (tmp_path / "profile.md").read_text()
    assert "| part of the plan |" in md and "Command:" in md
    assert (tmp_path / "profile_parts.png").stat().st_size > 0 and "<html" in (tmp_path / "profile.html").read_text()
    assert "AmpLs._plan_once" in (tmp_path / "profile.txt").read_text()
