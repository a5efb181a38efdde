"""The fault cases' failure messages say what the planner reported."""

import time

from latent_planner_ros.evaluation.fault_context import Ctx
from latent_planner_ros.evaluation.probes.fault_probe import Status


class FakeProbe:
    def __init__(self, states, commands):
        now = time.monotonic()
        self.statuses = [Status(now, 0, "", {"state": s, "pos_err_m": 0.1}) for s in states]
        self.commands = [(now, None, 0.0)] * commands

    def statuses_since(self, node, t):
        return [s for s in self.statuses if s.t >= t]

    def commands_since(self, t):
        return [c for c in self.commands if c[0] >= t]


def test_the_story_lists_the_planner_states_in_order_with_counts():
    ctx = Ctx(None, "scene")
    ctx.probe = FakeProbe(["tracking", "tracking", "holding", "tracking"], commands=7)
    story = ctx.story(time.monotonic() - 5.0)
    assert story.startswith("planner states: tracking x2, holding x1, tracking x1; last status: {")
    assert "'pos_err_m': 0.1" in story and story.endswith("; 7 commands/s")
    ctx.probe = FakeProbe([], commands=0)
    assert ctx.story(time.monotonic() - 5.0) == "planner states: no status; last status: -; 0 commands/s"
