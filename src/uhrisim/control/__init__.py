"""Controllers: turn DESIRED_HEADING/SPEED/DEPTH into actuator inputs of each model."""
