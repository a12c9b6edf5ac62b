"""Benchmarks: each measures its cases in one process and writes JSON (see docs/architecture.md)."""
