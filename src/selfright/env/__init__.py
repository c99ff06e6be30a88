"""The recovery environment: fall protocol, goal set, observations, rewards, randomisation."""
