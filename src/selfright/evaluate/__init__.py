"""Grid evaluation: episode runner, per-cell metrics, result files."""
