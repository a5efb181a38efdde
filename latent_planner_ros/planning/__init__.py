"""Planners: AMP-LS (latent-space activation maximisation), collision backends, OMPL baseline."""
