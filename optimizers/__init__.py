"""Swarm and reference optimisers behind one small interface (knows nothing about UAVs)."""
