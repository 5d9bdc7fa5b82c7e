"""Solvers: the patches' radiosity from B = E + rho F B, by progressive refinement, Jacobi or
Gauss-Seidel, level by level of adaptive refinement, with Monte Carlo for what shots leave."""
