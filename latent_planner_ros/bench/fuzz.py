"""`bench fuzz`: property-based fuzzing of every input boundary, the long profile of test/fuzz.

    python -m latent_planner_ros bench fuzz --examples 10000 --out DIR [--node-examples N] [--only NAMES] [--seed S]

Feeds `--examples` generated inputs (hypothesis) to each message adapter that converts an incoming message
(latent_planner_ros/bench/fuzz_adapters.py) and `--node-examples` (default: the same) to each subscriber,
service and parameter callback of the planner, ompl_planner, scene_encoder and sim nodes, built in-process
(bench/fuzz_nodes.py; plans cut at 0.5 s). Nothing stops at a finding: every input runs, and each escaped
exception (any exception leaving a callback, or any but AdapterError leaving an adapter) and each invariant
violation (a refusal without a reason, a bad accepted result, a command outside the joint limits) is counted and
its first input kept. After a node's boundaries its parameters are set back and valid inputs must still be handled.
Writes DIR/fuzz.json (per boundary: inputs, accepted, refused, failed plans, escaped, invariant_violations,
wall_s; totals; `valid_after` per node), DIR/fuzz.md and DIR/fuzz_outcomes.png. Exit code 0 when nothing escaped
and no invariant broke.
"""

from __future__ import annotations

import sys
import time
from collections import Counter

from latent_planner_ros.bench.report import bench_parser, write_report


def _describe(msg) -> str:
    """The input as text: a parameter (or a list of them) by name, type and value, anything else by repr."""
    items = msg if isinstance(msg, list | tuple) else [msg]
    if items and all(hasattr(p, "name") and hasattr(p, "value") and hasattr(p, "type_") for p in items):
        return ", ".join(f"{p.name} = {p.value!r} ({p.type_.name})" for p in items)
    return repr(msg)


def run_boundary(boundary, examples: int, seed: int) -> dict:
    """Run `examples` generated inputs through boundary.check, catching everything; a summary dict."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hypothesis_seed

    from latent_planner_ros.bench.fuzz_adapters import InvariantError

    counts: Counter = Counter()
    findings: dict[str, dict] = {}

    def record(kind: str, err: Exception, msg) -> None:
        counts[kind] += 1
        key = f"{kind}: {type(err).__name__}: {str(err).splitlines()[0][:160] if str(err) else ''}"
        if key not in findings:
            findings[key] = {"count": 0, "input": _describe(msg)[:600]}
        findings[key]["count"] += 1

    @hypothesis_seed(seed)
    @settings(
        max_examples=examples,
        database=None,
        deadline=None,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    @given(boundary.strategy)
    def run(msg):
        counts["inputs"] += 1
        try:
            counts[boundary.check(msg)] += 1
        except InvariantError as err:
            record("invariant_violations", err, msg)
        except Exception as err:  # noqa: BLE001 - counting what escapes is the point
            record("escaped", err, msg)

    t0 = time.perf_counter()
    run()
    return {
        "inputs": counts["inputs"],
        "accepted": counts["accepted"],
        "refused": counts["refused"],
        "failed": counts["failed"],
        "escaped": counts["escaped"],
        "invariant_violations": counts["invariant_violations"],
        "findings": findings,
        "wall_s": round(time.perf_counter() - t0, 1),
    }


def _requested(n: int, run: int | None, what: str) -> str:
    """ "10000 generated inputs requested per adapter (9 run)", or "no adapter run" (run None: not recorded)."""
    if run == 0:
        return f"no {what} run"
    return f"{n} generated inputs requested per {what}" + ("" if run is None else f" ({run} run)")


def markdown(res: dict) -> str:
    lines = [
        "# Property-based fuzzing of every input boundary",
        "",
        f"{_requested(res['examples'], res.get('adapters_run'), 'adapter')}, "
        f"{_requested(res['node_examples'], res.get('node_callbacks_run'), 'node callback')} "
        f"(hypothesis seed {res['seed']}). Escaped exceptions: **{res['escaped_total']}**, invariant violations: "
        f"**{res['invariant_violations_total']}**, fewest inputs at one boundary: {res['inputs_min']}.",
        "",
        "| boundary | inputs | accepted | refused | failed plans | escaped | invariant violations | wall [s] |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, b in res["boundaries"].items():
        lines.append(
            f"| {name} | {b['inputs']} | {b['accepted']} | {b['refused']} | {b['failed']} | {b['escaped']} | "
            f"{b['invariant_violations']} | {b['wall_s']:.1f} |"
        )
    if res["valid_after"]:
        lines += ["", "Valid inputs after the fuzzing (parameters set back first):", ""]
        lines += [f"- {node}: {text}" for node, text in res["valid_after"].items()]
    found = [(name, key, f) for name, b in res["boundaries"].items() for key, f in b["findings"].items()]
    if found:
        lines += ["", "## Findings", "", "| boundary | finding | count | first input |", "| --- | --- | --- | --- |"]
        for name, key, f in found:
            text = f["input"][:300].replace("|", "/")
            lines.append(f"| {name} | {key.replace('|', '/')} | {f['count']} | `{text}` |")
    return "\n".join(lines) + "\n"


def figure(res: dict):
    import matplotlib.pyplot as plt
    import numpy as np

    names = list(res["boundaries"])
    fig, ax = plt.subplots(figsize=(7, max(3.0, 0.28 * len(names))))
    y, left = np.arange(len(names)), np.zeros(len(names))
    for key, colour in (("accepted", "tab:green"), ("refused", "tab:blue"), ("failed", "tab:orange"),
                        ("escaped", "tab:red"), ("invariant_violations", "tab:purple")):  # fmt: skip
        share = np.array([res["boundaries"][n][key] / max(1, res["boundaries"][n]["inputs"]) for n in names])
        ax.barh(y, share, left=left, color=colour, label=key.replace("_", " "))
        left += share
    ax.set_yticks(y, names, fontsize=7)
    ax.invert_yaxis()
    ax.set(xlabel="share of the generated inputs", xlim=(0, 1))
    ax.set_title(f"{res['escaped_total']} escaped exceptions, {res['invariant_violations_total']} invariant violations")
    ax.legend(loc="lower right", fontsize=7)
    return fig


def main(argv: list[str]) -> int:
    p = bench_parser("fuzz", __doc__.split("\n\n")[0])
    p.add_argument("--examples", type=int, default=10_000, help="generated inputs per adapter boundary")
    p.add_argument("--node-examples", type=int, help="generated inputs per node callback (default: --examples)")
    p.add_argument("--only", default="", help="comma-separated prefixes of boundary names (default: all)")
    p.add_argument("--seed", type=int, default=0, help="hypothesis seed")
    args = p.parse_args(argv)
    node_examples = args.node_examples if args.node_examples is not None else args.examples
    if args.examples < 1 or node_examples < 1:
        p.error("--examples and --node-examples must be at least 1")
    only = tuple(s.strip() for s in args.only.split(",") if s.strip())

    def wanted(name: str) -> bool:
        return not only or name.startswith(only)

    from latent_planner_ros.bench.fuzz_adapters import ADAPTER_BOUNDARIES

    boundaries: dict[str, dict] = {}
    valid_after: dict[str, str] = {}
    t0 = time.monotonic()

    def run(boundary, n: int) -> None:
        print(f"[bench fuzz] {boundary.name}: {n} inputs ...", file=sys.stderr, flush=True)
        boundaries[boundary.name] = out = run_boundary(boundary, n, args.seed)
        print(f"[bench fuzz]   {out['inputs']} inputs, {out['escaped']} escaped, {out['invariant_violations']} "
              f"invariant violations, {out['wall_s']:.0f} s", file=sys.stderr, flush=True)  # fmt: skip

    for boundary in ADAPTER_BOUNDARIES:
        if wanted(boundary.name):
            run(boundary, args.examples)
    adapters_run = len(boundaries)
    nodes_wanted = [n for n in _node_names() if not only or any(n.startswith(o) or o.startswith(n) for o in only)]
    if nodes_wanted:
        import rclpy

        from latent_planner_ros.bench.fuzz_nodes import build

        rclpy.init()
        try:
            for node in nodes_wanted:
                fuzz = build(node)
                try:
                    for name, boundary in fuzz.all_boundaries().items():
                        if wanted(name):
                            run(boundary, node_examples)
                    fuzz.restore_parameters()
                    fuzz.handles_valid_input()
                    valid_after[node] = "handled"
                except Exception as err:  # noqa: BLE001 - reported, and the exit code says so
                    valid_after[node] = f"NOT handled: {type(err).__name__}: {err}"
                finally:
                    fuzz.close()
        finally:
            rclpy.try_shutdown()

    res = {
        "examples": args.examples,
        "node_examples": node_examples,
        "seed": args.seed,
        "boundaries": boundaries,
        "adapters_run": adapters_run,
        "node_callbacks_run": len(boundaries) - adapters_run,
        "valid_after": valid_after,
        "inputs_min": min((b["inputs"] for b in boundaries.values()), default=0),
        "escaped_total": sum(b["escaped"] for b in boundaries.values()),
        "invariant_violations_total": sum(b["invariant_violations"] for b in boundaries.values()),
        "wall_s": round(time.monotonic() - t0, 1),
    }
    write_report(args.out, "fuzz", res, markdown(res), {"outcomes": figure(res)}, argv)
    ok = res["escaped_total"] == 0 and res["invariant_violations_total"] == 0
    ok = ok and all(v == "handled" for v in valid_after.values())
    totals = f"{res['escaped_total']} escaped, {res['invariant_violations_total']} invariant violations"
    print(f"[bench fuzz] {len(boundaries)} boundaries, {totals}, {res['wall_s']:.0f} s", file=sys.stderr)
    return 0 if ok else 1


def _node_names() -> tuple[str, ...]:
    from latent_planner_ros.bench.fuzz_nodes import NODE_BOUNDARIES

    return tuple(NODE_BOUNDARIES)
