"""A library must leave the process's warning filters alone, even for a moment: another thread's
warnings meet whatever filters are in place at the time. Checked at every Python call the work
makes, so the check does not depend on when threads switch."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable


def assert_warning_filters_untouched(work: Callable[[], None]) -> None:
    """Run `work`; fail if, at any Python call it makes, `warnings.filters` is another list or holds
    other filters than before (what `warnings.catch_warnings` with a filter does)."""
    original, before, changed = warnings.filters, list(warnings.filters), []

    def at_each_call(frame, event, arg):  # noqa: ANN001, ANN202 (sys.settrace's signature)
        if warnings.filters is not original or warnings.filters != before:
            changed.append(f"{frame.f_code.co_filename}:{frame.f_code.co_name}")
        return None

    previous = sys.gettrace()
    sys.settrace(at_each_call)
    try:
        work()
    finally:
        sys.settrace(previous)
    assert not changed, f"the warning filters were changed, seen at {changed[:3]}"
