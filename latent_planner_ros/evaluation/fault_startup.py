"""Start-up faults: each misconfigured node runs alone and must exit non-zero with a clear error. No rclpy.

Missing, corrupt and mismatched checkpoints (weights, metadata) and bad parameter values, for the planner, the
scene_encoder and the sim; a case survives when the process exits non-zero, its output holds
``cannot start: <reason>`` with the expected reason, and no traceback.
"""

from __future__ import annotations

import concurrent.futures
import subprocess
import tempfile
import time
from pathlib import Path

from latent_planner_ros.evaluation.fault_context import CaseResult


def _write_corrupt(stem: Path) -> Path:
    stem.parent.mkdir(parents=True, exist_ok=True)
    stem.with_suffix(".safetensors").write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{not safetensors")
    stem.with_suffix(".json").write_text("{}\n")
    return stem


def startup_cases(tmp: Path) -> dict[str, tuple[str, list[str], str]]:
    """name -> (node, ``-p`` arguments, text its error must contain)."""
    from latent_planner_ros.models.vae_io import shipped_vae_path

    corrupt = _write_corrupt(tmp / "corrupt")
    bad_json = _write_corrupt(tmp / "bad_json")
    bad_json.with_suffix(".json").write_text("{ not json")
    missing = tmp / "missing" / "nothing"
    vae = shipped_vae_path()
    return {
        "startup_planner_missing_vae": ("planner", [f"vae_checkpoint:={missing}"], "checkpoint file missing"),
        "startup_planner_corrupt_vae": ("planner", [f"vae_checkpoint:={corrupt}"], "truncated or corrupt"),
        "startup_planner_vae_metadata_not_json": ("planner", [f"vae_checkpoint:={bad_json}"], "is not valid JSON"),
        "startup_planner_missing_collision": (
            "planner",
            ["amp_ls.collision_backend:=learned", f"collision_checkpoint:={missing}"],
            "checkpoint file missing",
        ),
        "startup_planner_missing_lspp": ("planner", [f"lspp_checkpoint:={missing}"], "checkpoint file missing"),
        "startup_planner_wrong_lspp": ("planner", [f"lspp_checkpoint:={vae}"], "is not an LSPP cylinder classifier"),
        "startup_encoder_corrupt_checkpoint": ("scene_encoder", [f"checkpoint:={corrupt}"], "truncated or corrupt"),
        "startup_encoder_wrong_checkpoint": ("scene_encoder", [f"checkpoint:={vae}"], "is not a collision network"),
        "startup_planner_bad_rate": ("planner", ["closed_loop.rate_hz:=-5.0"], "rate_hz must be a positive"),
        "startup_planner_bad_backend": ("planner", ["amp_ls.collision_backend:=bogus"], "collision_backend must be"),
        "startup_encoder_bad_max_points": ("scene_encoder", ["max_points:=0"], "max_points: 0 is outside its"),
        "startup_sim_bad_timestep": ("sim", ["timestep:=-0.002"], "timestep"),
        "startup_sim_missing_scenario": ("sim", ["scenario:=/nonexistent/scene.yaml"], "nonexistent"),
    }


def _run_startup(node: str, params: list[str], env: dict, timeout_s: float = 90.0) -> tuple[int | None, str, float]:
    """(exit code or None if it kept running, its output, wall time [s]) of one node start."""
    from latent_planner_ros.processes.node_suite import find_params_file, node_argv

    argv = node_argv(node, params, find_params_file(node), use_sim_time=False)
    t0 = time.monotonic()
    try:
        proc = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired as err:
        out = f"still running after {timeout_s:g} s: {err.stdout or ''}{err.stderr or ''}"
        return None, out, time.monotonic() - t0
    return proc.returncode, proc.stdout + proc.stderr, time.monotonic() - t0


def run_startup_group(domain_id: int | None = None, workers: int = 2) -> list[CaseResult]:
    """Start each misconfigured node alone; it must exit non-zero with a clear 'cannot start: <reason>'."""
    from latent_planner_ros.processes.node_suite import suite_env

    env = suite_env(domain_id, headless=True)
    results = []
    with tempfile.TemporaryDirectory(prefix="faults_startup_") as tmp:
        cases = startup_cases(Path(tmp))
        with concurrent.futures.ThreadPoolExecutor(max_workers=workers) as pool:
            futures = {
                name: (pool.submit(_run_startup, node, params, env), text)
                for name, (node, params, text) in cases.items()
            }
            for name, (future, text) in futures.items():
                code, output, took = future.result()
                r = CaseResult(name, "startup")
                lines = [x for x in output.splitlines() if "cannot start" in x]
                r.checks["exits non-zero"] = code not in (None, 0)
                r.checks["clear error at start"] = any(text in x for x in lines)
                r.notes.append(f"exit {code}: {lines[0].strip() if lines else output[-300:]}")
                r.checks["no traceback"] = "Traceback" not in output
                r.duration_s = took
                r.survived = all(r.checks.values())
                results.append(r)
    return results
