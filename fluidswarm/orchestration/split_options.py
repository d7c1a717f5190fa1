"""The options of a run split over hosts with workers (`--workers M`, docs/multi-host.md), given their defaults
once: read by the command line (fluidswarm/worker_command.py) and the run (run.py). No imports, so
registering the command line stays light."""

# How a run with workers cuts its swarm between the hosts: compact regions (agent/sph/regions.py: a host's
# agents are each other's neighbours) of the formation it is going to (`formation`: the kind's
# SwarmPlan.share_layout, share_layout.py) or of its start layout (`start`), or ranges of ids (what
# `launch --ids` does); the last two to compare (docs/multi-host.md)
SHARE_KINDS = ("formation", "start", "ids")
WORKERS_TIMEOUT = 120.0  # s the main host waits for its workers before it starts anything of its own
