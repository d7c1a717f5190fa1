"""Route following from gesture commands (issue 5): placeholder until the coordinator exists."""
