"""Collision-predictor data: procedural scenes, a virtual depth camera, exact collision labels."""
