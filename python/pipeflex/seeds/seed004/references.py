"""Seed 004 (floating frame of reference pipe bodies): the numbers it prints, stored once.

Reference data for comparison only: nothing here feeds a computation.
"""
from __future__ import annotations

#: Table 1 (3 decimals printed): final angular velocity [rad/s] of the semicircular pipe
#: per Young's modulus E [Pa], the seed's FFRF column.
TABLE1_FFRF = {0.9585e9: 5.320, 9.585e9: 9.117, 95.85e9: 9.954}
#: Table 1, the Spacar column (seed 000's element, for comparison).
TABLE1_SPACAR = {0.9585e9: 5.218, 9.585e9: 9.010, 95.85e9: 9.882}
