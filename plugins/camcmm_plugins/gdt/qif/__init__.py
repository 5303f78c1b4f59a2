"""QIF 3.0 (ANSI/DMSC QIF 3.0-2018, ISO 23952:2020) for GD&T plans and results: reading a
model-based definition into a plan, writing an evaluation's Results and reading them back."""
