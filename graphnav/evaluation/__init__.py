"""Scoring and comparing estimators: metrics, the method registry, the benchmark, fault injection, plots."""
