"""The navigator: estimation and avoidance composed (a facade, the obstacle view, the decider)."""
