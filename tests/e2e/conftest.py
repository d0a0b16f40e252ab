"""End-to-end suite hooks: the ArduPilot flight's figures in the terminal summary, so that CI
output shows them without -s."""
from __future__ import annotations


def pytest_terminal_summary(terminalreporter) -> None:
    lines = [value for reports in terminalreporter.stats.values() for report in reports
             for name, value in getattr(report, "user_properties", ())
             if name == "ardupilot_flight" and getattr(report, "when", "") == "call"]
    if lines:
        terminalreporter.section("ArduCopter SITL flight")
        for line in lines:
            terminalreporter.write_line(line)
