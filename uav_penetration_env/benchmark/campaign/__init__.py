"""Campaigns: a publication (or any sequence of ``uav-bench`` commands) run from a YAML file, resumably.

``uav-bench campaign FILE.yaml`` (:mod:`~uav_penetration_env.benchmark.commands.campaign`) reads
the file (:mod:`.spec`), plans its parts (:mod:`.plan`, the RL programme's agents from
:mod:`.agents`), runs what its compute log (:mod:`.log`) does not hold as done (:mod:`.runner`,
one command at a time through :mod:`.process`), and installs, accounts for (:mod:`.compute`) and
carries (:mod:`.carry`) the result. docs/publishing.md describes the file and the command.
"""
