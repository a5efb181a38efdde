"""Benchmark output: DIR/<suite>.json, DIR/<suite>.md and PNG figures, with the command and machine."""

from __future__ import annotations

import json
import os
import platform
import shlex
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def machine_info() -> dict:
    """Where a benchmark ran: CPU model, cores, Python, torch threads."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()}


def bench_command(suite: str, argv: list[str]) -> str:
    return f"python -m latent_planner_ros bench {suite} " + shlex.join(argv)


def write_report(
    out: Path, suite: str, results: dict, markdown: str, figures: dict[str, plt.Figure], argv: list[str]
) -> Path:
    """Write `<suite>.json` (results + provenance), `<suite>.md` (markdown + figure links) and PNGs.

    Returns the JSON path.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    command = bench_command(suite, argv)
    machine = machine_info()
    payload = dict(results)
    payload["_meta"] = {"command": command, "machine": machine, "date": time.strftime("%Y-%m-%d %H:%M:%S %Z")}
    json_path = out / f"{suite}.json"
    json_path.write_text(json.dumps(payload, indent=2, sort_keys=True) + "\n")
    lines = [markdown.rstrip(), ""]
    for name, fig in figures.items():
        png = out / f"{suite}_{name}.png"
        fig.savefig(png, dpi=110, bbox_inches="tight")
        plt.close(fig)
        lines.append(f"![{name}]({png.name})")
    lines += [
        "",
        f"Command: `{command}`  ",
        f"Machine: {machine['cpu']}, {machine['cores']} cores, Python {machine['python']}",
    ]
    (out / f"{suite}.md").write_text("\n".join(lines) + "\n")
    print(f"[bench {suite}] wrote {json_path}, {out / (suite + '.md')}", file=sys.stderr)
    return json_path


def bench_parser(suite: str, description: str):
    """An argparse parser with the common `--out DIR` option."""
    import argparse

    p = argparse.ArgumentParser(prog=f"latent-planner bench {suite}", description=description)
    p.add_argument("--out", type=Path, required=True, help="output directory")
    return p
