import os

# plots are written headless in tests
os.environ.setdefault("MPLBACKEND", "Agg")
