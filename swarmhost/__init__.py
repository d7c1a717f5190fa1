"""The runtime of a swarm on one host: the programs around the agents (docs/architecture.md, layer 5).

`launcher` composes the run's Zenoh router (`router_host`, `router_process`, `relay`), the agent processes
(`supervisor`, `executable`, `initial_neighbours`), the pacing clock (`pacing`), the recorder process
(`recorder_process`) and the watch on the run's helper processes (`helpers`). The agent itself — physics,
protocol, the compiled program — is the `agent` package.
"""
