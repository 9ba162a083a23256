"""Stable-Baselines3 baselines (the only package that imports torch)."""
