"""The switching NMPC on the paper's model (CasADi; never imports mujoco)."""
