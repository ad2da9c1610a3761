"""matplotlib with the Agg backend (files, no display), selected before pyplot loads."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["plt"]
