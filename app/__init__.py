"""CS-FEM multi-body contact with a modified Coulomb law solved as an LCP by Lemke."""
