"""Reconstruction: the colours at the receiver nodes corrected near each node, per triangle
corner, and an estimate of how far they may be from the converged answer."""
