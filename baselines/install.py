"""The one line that installs the ``rl`` extra, for every message that asks for it."""

from __future__ import annotations

# The CPU torch wheel goes first: a plain `pip install torch` (which the extra would run) pulls
# several GB of CUDA packages. docs/guide.md's "Installing" block gives the index to use.
CPU_TORCH = "pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu"
RL_INSTALL = (
    f"{CPU_TORCH} && pip install -e '.[rl]' (in a checkout; else pip install 'uav-penetration[rl]'): "
    "the CPU torch wheel first, since the extra alone pulls several GB of CUDA packages"
)
