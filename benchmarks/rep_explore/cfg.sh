CFG="rho=0.55 smax=0.7 A=0.8 kappa=0.85 spmode=1 lp_hz=3.0 beta=0.5 lagcomp=1 gamma=0.35 ext=1 rho_end=0.6"
