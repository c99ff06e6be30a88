"""Training stack: rsl_rl adapter, runners for teacher PPO and student distillation, export."""
