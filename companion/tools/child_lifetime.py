"""Children that do not outlive the process that started them.

On Linux a child started with ``preexec_fn=die_with_parent_hook()`` asks the kernel (prctl
PR_SET_PDEATHSIG) for SIGTERM when its parent goes, even by SIGKILL or an out-of-memory kill, so a
demo killed hard leaves no stub or daemon running with nobody to stop it. Elsewhere it is None
(no hook: the parent's own cleanup is all there is).

The kernel sends the signal when the *thread* that forked the child exits: start children from
a thread that lives as long as they should (asyncio's event loop thread does).
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys

PR_SET_PDEATHSIG = 1          # linux/prctl.h

# libc's symbols loaded now, in the parent: nothing may be loaded in a forked child before exec.
_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None


def _die_with_parent(parent_pid: int) -> None:
    """In the child, between fork and exec."""
    _LIBC.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != parent_pid:     # the parent died before the prctl took hold
        os._exit(1)


def die_with_parent_hook():
    """A ``preexec_fn`` for subprocess/asyncio that ties the child's life to this process, or
    None where the platform has no such thing."""
    if _LIBC is None:
        return None
    parent_pid = os.getpid()
    return lambda: _die_with_parent(parent_pid)


def die_with_parent_now() -> None:
    """The same tie, asked for by the child itself once running (a Dask worker's preload: its
    parent thread is the nanny's process-watch thread, which lives as long as the worker)."""
    if _LIBC is not None:
        _LIBC.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
