"""The MuJoCo plant: an independent physical UVMS built from the parameter file (no casadi)."""
