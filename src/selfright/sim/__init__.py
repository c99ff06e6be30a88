"""MuJoCo scene assembly and batched stepping."""
