"""Dask preload for `companion campaign`'s local workers: a worker gets SIGTERM when the
campaign process dies, even by SIGKILL (see companion/tools/child_lifetime.py)."""
from __future__ import annotations

from companion.tools.child_lifetime import die_with_parent_now


def dask_setup(worker=None) -> None:
    die_with_parent_now()
