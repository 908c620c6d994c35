"""Pipelines: one plain function per pipeline (inputs + parameters + progress → result)."""
