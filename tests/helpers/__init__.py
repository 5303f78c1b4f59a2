"""What the tests share: browser driving, CLI runs and refusals, generated data (one place;
``pythonpath = ["tests"]`` in pyproject.toml puts it on the path)."""
