"""A run as a whole (docs/architecture.md, orchestration): `run` one `Run` that starts, drives and scores a run
and returns its record; `run_config` the run's configuration, each default declared and checked once;
`imitate` and `imitate_camera` an imitation's kinds of run (a file, a camera); `share_layout` where a split run's
swarm is going; `split_options` the split options' defaults."""
