"""matplotlib for the experiments: the Agg backend (files, no display), selected before pyplot loads.

    from experiments.plotting import plt
"""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["plt"]
