"""Physics: beam FE, blade and rig assembly, analytical model, modal, contact, time integration, harmonic response."""
