"""The offline tools behind the commands: demo, ArduPilot SITL demo, replay, campaigns, reports."""
