"""The unified velocity MPC (docs/mpc.md): its model, QP, real-time iteration with the C driver, horizon, reference NLP, overlapped solve and the velocity controller built on them."""
