"""Navigation: occupancy maps, the agent's action model, the expert planner and the metrics."""
