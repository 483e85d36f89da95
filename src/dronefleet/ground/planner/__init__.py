"""Mission Planner (seed 3.4.2.4, 4.2.4): coverage, estimates, allocation, missions, extension."""
