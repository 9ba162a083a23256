"""The one line that installs the ``rl`` extra, for every message that asks for it."""

from __future__ import annotations

# The CPU torch wheel goes first: a plain `pip install torch` (which the extra would run) pulls
# several GB of CUDA packages. docs/guide.md's "Installing" block gives the index to use.
RL_INSTALL = (
    "pip install torch==2.13.0 from PyTorch's CPU index first (docs/guide.md, 'Installing', gives the "
    "command), then pip install -e '.[rl]' in a checkout, or pip install 'uav-penetration[rl]'"
)
