"""Learned models: the robot-state VAE, GECO, the scene encoder and collision predictor, checkpoint I/O."""
