"""STATUSTEXT rate limiting: a burst of notices must not flood the ground station's link."""
from __future__ import annotations

from collections import deque


class NoticeLimiter:
    """The same text at most once per ``repeat_s``, and at most ``per_s`` notices in any second.

    ``suppressed`` counts what was held back; :meth:`take_suppressed_report` says so once the
    budget allows (the count since the last report), so the operator knows notices were lost.
    """

    def __init__(self, repeat_s: float, per_s: int) -> None:
        self.repeat_s = repeat_s
        self.per_s = per_s
        self.suppressed = 0
        self._unreported = 0
        self._last_by_text: dict[str, float] = {}
        self._recent: deque[float] = deque()

    def admit(self, text: str, t_s: float) -> bool:
        """May a notice with ``text`` go out at ``t_s``? Counted if not."""
        while self._recent and self._recent[0] <= t_s - 1.0:
            self._recent.popleft()
        last = self._last_by_text.get(text)
        if (last is not None and t_s - last < self.repeat_s) or len(self._recent) >= self.per_s:
            self.suppressed += 1
            self._unreported += 1
            return False
        self._last_by_text[text] = t_s
        self._recent.append(t_s)
        if len(self._last_by_text) > 256:            # bounded: forget the oldest texts
            for old in sorted(self._last_by_text, key=self._last_by_text.get)[:128]:
                del self._last_by_text[old]
        return True

    def take_suppressed_report(self, t_s: float) -> str | None:
        """A text saying how many notices were held back since the last one, if it may go out."""
        if not self._unreported:
            return None
        text = f"companion: {self._unreported} notices suppressed"
        count = self._unreported
        if self.admit(text, t_s):
            self._unreported -= count
            return text
        self._unreported -= 1            # admit() counted this report itself: not a user notice
        self.suppressed -= 1
        return None
