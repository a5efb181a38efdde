"""Fault injection through the ROS graph: real nodes in subprocesses, every case of
``latent_planner_ros.bench.fault_cases`` (shared with ``bench faults``) must survive: no crash, the safety
invariant held for every joint_command, the reason on status/logs, normal operation after the fault.

One test per group, so one suite start-up serves many cases.
"""

from __future__ import annotations

import pytest

from latent_planner_ros.bench.fault_cases import group_cases, run_group, summarise


def _report(results, info) -> str:
    lines = [f"group {info.name}: backend {info.backend or '-'}, nodes {info.nodes}, notes {info.notes}"]
    for r in results:
        lines.append(f"  {r.name}: {'survived' if r.survived else 'FAILED ' + ', '.join(r.failures())}")
        lines += [f"    {n}" for n in r.notes if not r.survived]
    return "\n".join(lines)


def _run(group: str, tmp_path):
    results, info = run_group(group, log_path=tmp_path / "nodes.log")
    report = _report(results, info)
    if any(not r.survived for r in results):
        log = (tmp_path / "nodes.log").read_text()[-4000:]
        report += f"\n--- node output (tail) ---\n{log}"
    return results, info, report


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(420)
@pytest.mark.parametrize("group", ["inputs", "scene", "sim"])
def test_every_fault_case_is_survived(group, tmp_path):
    results, info, report = _run(group, tmp_path)
    assert [r.name for r in results] == [name for name, _ in group_cases(group, info.backend)], report
    summary = summarise(results)
    assert summary["failed"] == [] and summary["invariant_violations"] == 0, report
    assert all(code == 0 for code in info.exit_codes.values()), (info.exit_codes, report)
    if group == "scene":
        load = info.figures["load"]["loaded"]
        assert load["ticks_reported"] > 0 and load["commands_per_s"] >= 1.0, load


@pytest.mark.ros
@pytest.mark.slow
def test_misconfigured_nodes_exit_with_a_clear_error(tmp_path):
    results, info, report = _run("startup", tmp_path)
    assert len(results) >= 10 and all(r.survived for r in results), report
