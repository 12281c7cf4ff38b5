"""The input domain of the exact solver: where every answer is tested to be finite.

Outside it a box is physically meaningless for impactnet's users (a crane simulator), and the
arithmetic would leave float64's comfortable range: products of sizes near 1e300 overflow,
sizes near 1e-300 underflow the tolerances. Inputs outside the domain are refused with an
error naming the field, never answered with NaN. The service validates against the same
constants.
"""

#: Smallest accepted edge length, metres (1 um): 1e6 below a millimetre part, and the
#: relative tolerances (1e-12 of the pair's size) stay far above float64's underflow.
SIZE_MIN_M = 1e-6
#: Largest accepted edge length, metres (1000 km): squares and products stay far below
#: float64's overflow.
SIZE_MAX_M = 1e6
#: Largest accepted |coordinate| of a box centre, metres (1e6 km: any simulated world).
POSITION_MAX_M = 1e9
