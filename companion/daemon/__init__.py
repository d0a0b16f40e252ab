"""The asyncio shell of ``companion run``: link, tlog, timers and the pipeline in one task tree;
the parameter overlay file (param_overlay.py)."""
