"""The one exception type of the message adapters."""

from __future__ import annotations


class AdapterError(ValueError):
    """A ROS message (or an array meant to become one) cannot be converted.

    The message names the problem: the field, joint name, shape or value that was refused.
    A subclass of ValueError, so callers that already catch ValueError keep working.
    """
