"""Examples of docs/plugins.md: optimisers of your own, plugged into ``uav-bench run --import``."""
