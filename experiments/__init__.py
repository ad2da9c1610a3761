"""Experiment scripts (one per paper evaluation), data generators and benchmarks.

Run any of them as `python -m experiments.NAME --preset quick|paper --out DIR --seed S --field value`.
"""
