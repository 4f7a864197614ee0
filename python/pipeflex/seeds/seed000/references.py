"""Seed 000 (Meijaard & Hakvoort, 3D pipe element with flow): the numbers it prints, stored once.

Reference data for comparison only: nothing here feeds a computation.
"""
from __future__ import annotations

#: Table 1 (10 significant digits printed): critical mass flow [kg/s] of the simply
#: supported pipe (EI = 1 N m^2, L = 1 m, rho_p A_p = 0.75 kg/m, rho_f A_f = 0.25 kg/m,
#: k_v = 1) per number of elements.
TABLE1 = {1: 1.732050808, 2: 1.576693278, 4: 1.571198510, 8: 1.570822061, 16: 1.570797945}
#: Table 1, last row "infinity": the exact value pi (10 digits printed).
TABLE1_EXACT = 1.570796327
#: Table 2 (8 significant digits printed): critical mass flow [kg/s] of the cantilever pipe
#: (L = 1 m, EI = 10 N m^2, 8 kg/m, 2 kg/m, k_v = 1) per number of elements.
TABLE2 = {2: 24.962732, 4: 25.054732, 8: 25.008910, 16: 25.005738, 32: 25.005534}
#: Table 2, last row: the seed's extrapolation to infinitely many elements [kg/s].
TABLE2_EXTRAPOLATED = 25.005520
#: Section 3.3 (7 significant digits printed): final angular velocity [rad/s] of the
#: semicircular rotating pipe (R = 0.5 m, 0.5 and 1 kg/m, k_v = 1, mdot = 10 kg/s,
#: 8 curved elements) per bending stiffness EI [N m^2]; "rigid": the rigid pipe's 10 rad/s.
SPRINKLER = {10.0: 5.218466, 100.0: 9.009825, 1000.0: 9.882486, "rigid": 10.0}
