"""The in-process closed loop of ``companion simulate``: truth, random worlds, the plot."""
