"""Policy interface, baselines, learned policies and the context multiplexer."""
