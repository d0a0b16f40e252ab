"""Typed configuration: the schema (scenario and service), the YAML loader, bundled file paths."""
