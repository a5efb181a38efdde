"""How often the page's cloud changes: the view fed a 30k-point cloud at 20 Hz, watched in headless Chromium.

    .venv/bin/python test/view/rate.py [SECONDS]

Prints the cloud updates per second the page received (counted in the page, each animation frame comparing the
cloud's points buffer with the last one) and the view process's CPU share. docs/benchmark.md quotes it.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import time
from pathlib import Path

import psutil

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path[:0] = [str(HERE), str(REPO)]

from browser import chromium  # noqa: E402

COUNT_JS = """
window.__cloudUpdates = 0;
let last = null;
function tick() {
    const node = window.__viserSceneTree.getState()['/clouds/camera/points'];
    const points = node && node.message.props.points;
    if (points && points !== last) { window.__cloudUpdates += 1; last = points; }
    requestAnimationFrame(tick);
}
requestAnimationFrame(tick);
"""


def main(argv: list[str]) -> int:
    import importlib.util

    spec = importlib.util.spec_from_file_location("view_test", HERE / "test_view_browser.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    seconds = float(argv[0]) if argv else 10.0
    domain, port = random.SystemRandom().randint(1, 100), module._free_port()
    suite = module.FakeSuite(domain, cloud_hz=20.0)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    cmd = [sys.executable, "-m", "latent_planner_ros", "view", "--port", str(port)]
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    driver = None
    try:
        url = f"http://localhost:{port}"
        module._wait_http(url, proc)
        driver = chromium()
        driver.get(url)
        module._wait(lambda: (module.scene_nodes(driver) or {}).get("/clouds/camera/points"), 60.0, "the cloud")
        driver.execute_script(COUNT_JS)
        view = psutil.Process(proc.pid)
        view.cpu_percent()
        time.sleep(seconds)
        updates = driver.execute_script("return window.__cloudUpdates;")
        cpu = view.cpu_percent()
        print(f"30k-point cloud published at 20 Hz: {updates / seconds:.1f} updates/s in the page; view CPU {cpu:.0f}%")
    finally:
        if driver is not None:
            driver.quit()
        proc.terminate()
        proc.wait(timeout=10)
        suite.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
