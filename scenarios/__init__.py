"""The scenario catalogue (YAML scenarios, suites, sweeps, generators) as package data."""
