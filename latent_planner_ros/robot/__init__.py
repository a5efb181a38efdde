"""Panda model: description files, limits, FK (pinocchio and batched torch), collision, samplers."""
